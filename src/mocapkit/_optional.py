"""Optional dependencies: import them on use, with an error that says how to install them."""

from __future__ import annotations

import importlib
from types import ModuleType

# module name -> the pip extra of mocapkit that brings it
EXTRAS = {"matplotlib": "plot", "networkx": "graph"}


def require(module: str) -> ModuleType:
    """Import ``module`` or raise ImportError naming the extra to install, e.g.
    ``pip install 'mocapkit[plot]'`` for matplotlib."""
    try:
        return importlib.import_module(module)
    except ImportError as e:
        top = module.split(".")[0]
        extra = EXTRAS.get(top)
        hint = f"pip install 'mocapkit[{extra}]'" if extra else f"pip install {top}"
        raise ImportError(f"{module} is needed for this feature; install it with: {hint}") from e
