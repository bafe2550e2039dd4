"""Self-contained HTML viewer for motions, with cleaning, stitching and motion-graph overlays.

:func:`write_page` writes one HTML file that works offline (three.js and the data inlined);
:mod:`mocapkit.viz.browser` drives headless Chromium over the DevTools protocol (tests, bench).
"""

from mocapkit.viz.viewer import PALETTE, ViewMotion, build_page, page_data, write_page

__all__ = ["PALETTE", "ViewMotion", "build_page", "page_data", "write_page"]
