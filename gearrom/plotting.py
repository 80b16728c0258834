"""Figures of the result objects' ``plot`` methods: :func:`subplots`.

The figures are made with :class:`matplotlib.figure.Figure` directly, not through ``pyplot``: no
backend is selected or switched (a Jupyter kernel keeps its inline display, a script its own
backend), no figure stays registered in a pyplot figure list, and ``fig.savefig`` writes files
with any backend. Jupyter shows a returned figure through its inline formatter.
"""
from __future__ import annotations


def subplots(nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float] | None = None, **kw):
    """``(figure, axes)`` as :func:`matplotlib.pyplot.subplots` gives them, without pyplot.

    Parameters
    ----------
    nrows, ncols : int
        Grid of axes.
    figsize : (float, float), optional
        Width and height [inch].
    **kw
        Passed to :meth:`matplotlib.figure.Figure.subplots` (``sharex``, ``squeeze``, ``gridspec_kw``...).
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    return fig, fig.subplots(nrows, ncols, **kw)
