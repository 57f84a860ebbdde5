"""What an experiment on a twin produced: one result type for every machine."""

from __future__ import annotations

from dataclasses import dataclass

from ..log import Log


# ------------------------------------------------------------------------------------------ results
@dataclass(frozen=True)
class ExperimentResult:
    """What an experiment produced.

    Attributes
    ----------
    kind : str
        The experiment: ``"frf"``, ``"track"``, ``"ropesnap"``, ``"cut"``, ``"mass"``, ``"contour"``, ...
    log : Log
        The recorded signals (``meta["trip"]`` says why a run stopped early).
    run : TwinRun or GantryRun
        The raw closed-loop run (``tripped``, ``to_dict()``).
    summary : dict
        JSON-ready figures with units in the keys (metrics, settings).
    frf : Frf or None
        The estimated FRF (FRF experiments).
    metrics : object or None
        :class:`~feedtune.analysis.metrics.TrackingMetrics` or ``RopeSnapMetrics`` (None after a trip).
    """

    kind: str
    log: Log
    run: object
    summary: dict
    frf: object = None
    metrics: object = None

    @property
    def tripped(self) -> bool:
        """True when the safety envelope stopped the run."""
        return self.run.tripped

    def to_dict(self) -> dict:
        """``summary`` plus the run's duration and trip state."""
        return {"experiment": self.kind, **self.summary, "run": self.run.to_dict()}

    # --------------------------------------------------------------- notebooks
    def __repr__(self) -> str:
        from ..display import call, run_parts

        return call("ExperimentResult", run_parts(self))

    def plot(self, signals=None, *, title: str | None = None):
        """The run's key signals over time (:func:`feedtune.plotting.plot_run`); returns the matplotlib Figure."""
        from ..display import facade

        return facade("plot_run")(self, signals, title=title)
