"""Scripted models that run: :class:`ModelBuilder` with :meth:`~ModelBuilder.run`.

The deck layer's :class:`spacarpy.deck.api.ModelBuilder` writes and checks a model, keyword by
keyword; the deck layer may not import the solvers or the results (docs/architecture.md,
"Layers"), so running it lives here, in the driver layer. ``spacarpy.ModelBuilder`` is this
class::

    from spacarpy import ModelBuilder

    res = (ModelBuilder().mode("transient")
           .x(1, 0, 0, 0).x(3, 1, 0, 0).rbeam(1, 1, 4, 3, (0, 1, 0))
           .hinge(10, 2, 4, (0, 0, 1)).rlse(10, 1).fix(1).fix(2)
           .em(1, 2.0).gravity(0, -9.81, 0).timestep(2.2, 440)
           .run(progress=lambda done, total: print(f"{done / total:.0%}", end="\\r")))
    res.transient.position(node=3)          # (441, 3), in memory
    res.transient.to_xarray()               # labelled, with units

This module's one job is that method; the in-memory run is :func:`spacarpy.run.run_in_memory`.
"""
from __future__ import annotations

from spacarpy.deck.api import ModelBuilder as _DeckModelBuilder
from spacarpy.run import RunOptions, run_in_memory

__all__ = ["ModelBuilder"]


class ModelBuilder(_DeckModelBuilder):
    """:class:`spacarpy.deck.api.ModelBuilder` (one method per deck keyword) that also runs
    its model: :meth:`run`."""

    def run(self, out=None, *, progress=None, analysis: str | None = None,
            deformations: str | None = None, options: RunOptions | None = None):
        """Build the model (as :meth:`build_job`), run its analysis and return the results.

        Parameters
        ----------
        out : str or os.PathLike, optional
            Also write the results file there (and read the views from it). Without it the
            results stay in memory (:class:`~spacarpy.results.in_memory.InMemoryResults`;
            its ``write(path)`` saves them later).
        progress : callable, optional
            ``progress(done, total)``, called as the run goes: after every stored load step
            of a static path (``done`` the step, ``total`` the number of load steps) and
            after every time step of a transient (``done`` the time reached, ``total`` the
            end time, s); ``done / total`` is the fraction done in both. For example
            ``tqdm``: ``bar = tqdm(total=1.0); progress=lambda d, t: bar.update(d / t -
            bar.n)``.
        analysis, deformations : str, optional
            Override :meth:`mode` / :meth:`deformations` (like the command line's ``--mode``).
        options : RunOptions, optional
            Further run options (compliance node, user routines); ``progress`` fills its
            ``progress`` and ``step_progress`` hooks.

        Returns
        -------
        ResultsFile
            The views (``.static``, ``.transient``, ``.eigen``, ``.buckling``, ...), with the
            run's :class:`~spacarpy.run.RunSummary` as ``.summary``; MODE check returns
            the :class:`~spacarpy.run.RunSummary` (its ``report``).

        Raises
        ------
        DeckError
            The model is invalid (located at the script lines).
        SpacarError
            The analysis cannot run or fails (one line, as the command line says it).
        """
        job = self.build_job(deformations=deformations, analysis=analysis)
        opts = options if options is not None else RunOptions()
        if progress is not None:
            from dataclasses import replace
            opts = replace(opts, progress=progress, step_progress=progress)
        return run_in_memory(job, out, opts)
