"""The one plotting helper of the experiments: matplotlib on the file-only Agg backend, on demand.

Experiments call ``pyplot()`` inside the function that draws, so importing a core module (or
running a test) never imports matplotlib; only a run that writes a figure pays for it.
"""

from __future__ import annotations


def pyplot():
    """``matplotlib.pyplot`` with the Agg backend (PNG files, no display needed)."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    return plt
