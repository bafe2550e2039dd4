"""Library jobs: a per-item function (the same one the single-file command calls) mapped over
the files of a library, in this process or on Dask (a local cluster mocapkit starts, or a
running scheduler), with results in input order, atomic outputs and resume by manifest.

* :class:`Runner` -- where a job runs (:mod:`mocapkit.batch.runner`);
* :mod:`mocapkit.batch.manifest` -- input hashes and output hashes per item, for resume;
* :func:`clean_library` -- every take of a library cleaned against its related takes, with a
  summary (:mod:`mocapkit.batch.clean_library`);
* :func:`convert_folder`, :func:`info_folder`, :func:`graph_minima` -- the folder modes of
  ``convert`` and ``info`` and the tiles of ``graph build`` (:mod:`mocapkit.batch.jobs`).
"""

from mocapkit.batch.clean_library import (
    CONTEXT_BY,
    LibraryClean,
    LibraryCleanConfig,
    clean_library,
    context_of,
    find_takes,
)
from mocapkit.batch.manifest import Manifest, file_sha256, input_key
from mocapkit.batch.runner import RUNNER_HELP, JobError, Runner, RunStats

__all__ = [
    "CONTEXT_BY",
    "RUNNER_HELP",
    "JobError",
    "LibraryClean",
    "LibraryCleanConfig",
    "Manifest",
    "RunStats",
    "Runner",
    "clean_library",
    "context_of",
    "file_sha256",
    "find_takes",
    "input_key",
]
