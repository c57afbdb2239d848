"""Reports and figures: the only package that imports matplotlib.

Importing any module of this package selects matplotlib's non-interactive ``Agg`` backend first
(here, once), so figures are written to files without a display, also on headless machines.
"""

import matplotlib

matplotlib.use("Agg")
