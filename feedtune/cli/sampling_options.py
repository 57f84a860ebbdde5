"""The target's sample rate and computational delay for ``design``, ``tune`` and ``analyze``: one rule for all.

The rule (``docs/commands.md``, "Sample rate of the target"):

1. ``--fs`` given: it is used (``fs_source = "option"``). Every FRF that records a sample rate (metadata
   ``sampling_fs_hz``, written by ``feedtune frf`` and ``feedtune simulate frf``) must agree with it within 0.1 %
   (:data:`feedtune.frf_sampling.FS_TOLERANCE`); otherwise a usage error (exit 2) names the file and both rates,
   unless ``--fs-override`` turns it into a warning on stderr.
2. ``--fs`` not given: the rate the FRFs record (``"frf"``); two FRFs recording different rates are a usage error
   naming both.
3. Neither: the command's default (``"default"``), named in the summary and in ``--json``.

The computational delay follows the same order without the consistency check against an option:
``--delay-samples``, else the FRFs' ``sampling_delay_samples`` (a whole number), else 1. For ``analyze`` the
gains file's ``sampling.fs_hz`` takes the place of ``--fs`` (``fs_source = "gains"``).

Every FRF whose last line lies below a quarter of the target's Nyquist frequency draws a warning
(:func:`feedtune.frf_sampling.band_warning`). Warnings go to stderr in a summary; ``--json`` results carry them
instead, with ``fs_hz``, ``fs_source``, ``delay_samples`` and ``delay_source`` (:meth:`TargetSampling.to_json`;
``analyze`` adds these keys when it is given an FRF).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import typer

from .envelope import cli_text

#: Computational delay [samples] when neither ``--delay-samples`` nor an FRF gives one.
DEFAULT_DELAY_SAMPLES = 1

FS_OVERRIDE_OPTION = typer.Option(
    False, "--fs-override",
    help="Proceed (with a warning) when the target's sample rate disagrees by more than 0.1 % with the rate an FRF "
         "file records (its sampling_fs_hz); without it that is an error.")
DELAY_OPTION = typer.Option(
    None, "--delay-samples", metavar="N",
    help="Computational delay [samples] (default: the one an FRF file records, sampling_delay_samples, else 1).",
)


def fs_option(default: str) -> typer.models.OptionInfo:
    """The ``--fs`` option (default None: "not given"), its help naming the command's ``default`` rate."""
    return typer.Option(None, "--fs", metavar="HZ", help="Sample rate of the target [Hz] (default: the rate the FRF "
                                                         f"files record, sampling_fs_hz, else {default}).")


@dataclass(frozen=True)
class TargetSampling:
    """The sample rate and delay a command designs or analyses for, and where they came from.

    Attributes
    ----------
    fs_hz : float
        Sample rate of the target [Hz].
    fs_source : str
        ``"option"`` (``--fs``), ``"frf"`` (an FRF's ``sampling_fs_hz``), ``"gains"`` (the gains file) or
        ``"default"``.
    delay_samples : int
        Computational delay [samples].
    delay_source : str
        ``"option"``, ``"frf"``, ``"gains"`` or ``"default"``.
    fs_files : tuple of str
        The FRF files the rate was taken from (``fs_source == "frf"``).
    warnings : tuple of str
        One-line warnings (forced disagreement, FRF far below the Nyquist frequency, unusable delay record).
    """

    fs_hz: float
    fs_source: str
    delay_samples: int
    delay_source: str
    fs_files: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()

    def to_json(self) -> dict:
        """``fs_hz`` [Hz], ``fs_source``, ``delay_samples`` [samples], ``delay_source``, ``sampling_warnings``."""
        return {"fs_hz": self.fs_hz, "fs_source": self.fs_source, "delay_samples": self.delay_samples,
                "delay_source": self.delay_source, "sampling_warnings": list(self.warnings)}

    def describe(self, command: str = "") -> str:
        """One summary line: the rate, the delay and where each came from."""
        where = {"option": "--fs", "gains": "the gains file",
                 "frf": "recorded in " + ", ".join(self.fs_files),
                 "default": f"default{' of ' + command if command else ''}: no --fs, no rate recorded in an FRF"}
        delay_where = {"option": "--delay-samples", "gains": "the gains file", "frf": "recorded in the FRF",
                       "default": "default"}
        return (f"target sample rate {self.fs_hz:g} Hz ({where[self.fs_source]}), computational delay "
                f"{self.delay_samples} sample(s) ({delay_where[self.delay_source]})")

    def report(self, as_json: bool, command: str = "") -> None:
        """In a summary: the warnings on stderr, and the line of :meth:`describe` when the rate is a default or an
        FRF's, or the delay an FRF's. With ``--json`` nothing: the result carries them (:meth:`to_json`, and the
        envelope's ``warnings``), and stdout stays one JSON object also where stderr is merged into it."""
        from .envelope import collect

        collect(*self.warnings)
        if as_json:
            return
        for w in self.warnings:
            typer.echo(f"feedtune: warning: {cli_text(w)}", err=True)
        if self.fs_source in ("frf", "default") or self.delay_source == "frf":
            typer.echo(self.describe(command))


def _named(frfs: Sequence[tuple[object, object]]) -> list[tuple[str, object]]:
    return [(str(name), frf) for name, frf in frfs if frf is not None]


def _recorded(frfs: list[tuple[str, object]], reader: Callable[[object, str], float | None]
              ) -> list[tuple[str, float]]:
    """``(name, value)`` of the FRFs whose record ``reader(frf, name)`` finds."""
    out = []
    for name, frf in frfs:
        value = reader(frf, name)
        if value is not None:
            out.append((name, value))
    return out


def _fs_from_frfs(recorded: list[tuple[str, float]]) -> tuple[float, tuple[str, ...]]:
    """The one rate the FRFs record; DataError naming two files that disagree."""
    from ..errors import DataError
    from ..frf_sampling import rates_disagree

    first, fs = recorded[0]
    for name, value in recorded[1:]:
        if rates_disagree(value, fs):
            raise DataError(f"{first} records a sample rate of {fs:g} Hz but {name} records {value:g} Hz "
                             "(sampling_fs_hz); give the target's rate with --fs (and --fs-override)")
    return fs, tuple(name for name, _ in recorded)


def _delay_from_frfs(frfs: list[tuple[str, object]], warnings: list[str]) -> int | None:
    """The one whole delay the FRFs record, None when none does (a fractional record is a warning)."""
    from ..errors import DataError
    from ..frf_sampling import recorded_delay

    recorded = _recorded(frfs, recorded_delay)
    whole = []
    for name, value in recorded:
        if value != int(value):
            warnings.append(f"{name} records a computational delay of {value:g} samples; the controller's delay is "
                            f"a whole number of samples: using {DEFAULT_DELAY_SAMPLES} (pass --delay-samples)")
        else:
            whole.append((name, int(value)))
    if not whole:
        return None
    first, delay = whole[0]
    for name, value in whole[1:]:
        if value != delay:
            raise DataError(f"{first} records a computational delay of {delay} sample(s) but {name} records "
                             f"{value} (sampling_delay_samples); give the target's delay with --delay-samples")
    return delay


def target_sampling(fs: float | None, delay_samples: int | None, frfs: Sequence[tuple[object, object]], *,
                    default_fs: float, override: bool = False, given_by: str = "--fs",
                    given_source: str = "option") -> TargetSampling:
    """Sample rate and delay of the target by the rule of this module, with the warnings to print.

    Parameters
    ----------
    fs : float or None
        ``--fs`` [Hz] (or the gains file's rate), None when not given.
    delay_samples : int or None
        ``--delay-samples`` [samples] (or the gains file's delay), None when not given.
    frfs : sequence of (name, Frf or None)
        The FRF files the command reads, by file name (None entries are skipped).
    default_fs : float
        The command's default rate [Hz].
    override : bool
        ``--fs-override``: a disagreement between ``fs`` and an FRF's recorded rate is a warning, not an error.
    given_by : str
        What set ``fs`` (``"--fs"``, ``"GAINS's sampling.fs_hz"``), for messages.
    given_source : str
        ``fs_source`` / ``delay_source`` of a given value (``"option"``, ``"gains"``).

    Returns
    -------
    TargetSampling

    Raises
    ------
    UsageError
        ``fs`` or ``delay_samples`` out of range.
    DataError
        ``fs`` disagrees with an FRF's recorded rate by more than 0.1 % without ``override``; two FRFs record
        different rates (or delays) and nothing was given; an FRF's sampling record is not a number.
    """
    import math

    from ..errors import DataError, UsageError
    from ..frf_sampling import band_warning, rates_disagree, recorded_fs

    named = _named(frfs)
    warnings: list[str] = []
    recorded = _recorded(named, recorded_fs)
    files: tuple[str, ...] = ()
    from ..control.discretize import FS_MAX_HZ, FS_MIN_HZ, MAX_DELAY_SAMPLES

    if fs is not None:
        if not (math.isfinite(fs) and FS_MIN_HZ <= fs <= FS_MAX_HZ):
            raise UsageError(f"{given_by} must be a controller's sample rate in {FS_MIN_HZ:g} .. {FS_MAX_HZ / 1e6:g} "
                             f"MHz (slower loops cannot act on a drive's mechanics), got {fs:g}")
        fs_hz, fs_source = float(fs), given_source
        for name, value in recorded:
            if not rates_disagree(fs_hz, value):
                continue
            text = f"{name} records a sample rate of {value:g} Hz (sampling_fs_hz), but {given_by} is {fs_hz:g} Hz"
            if not override:
                fix = "omit --fs to use the recorded rate, or " if given_source == "option" else ""
                raise DataError(f"{text}; {fix}pass --fs-override to proceed at {fs_hz:g} Hz anyway")
            warnings.append(f"{text}: proceeding at {fs_hz:g} Hz (--fs-override)")
    elif recorded:
        (fs_hz, files), fs_source = _fs_from_frfs(recorded), "frf"
    else:
        fs_hz, fs_source = float(default_fs), "default"
    if delay_samples is not None:
        if isinstance(delay_samples, bool) or int(delay_samples) != delay_samples or \
                not 0 <= delay_samples <= MAX_DELAY_SAMPLES:
            raise UsageError(f"--delay-samples must be an integer in 0 .. {MAX_DELAY_SAMPLES} (a drive's computational "
                             f"delay), got {delay_samples}")
        delay, delay_source = int(delay_samples), given_source
    else:
        found = _delay_from_frfs(named, warnings)
        delay, delay_source = ((DEFAULT_DELAY_SAMPLES, "default") if found is None else (found, "frf"))
    for name, frf in named:
        w = band_warning(frf, fs_hz, name)
        if w:
            warnings.append(w)
    return TargetSampling(fs_hz, fs_source, delay, delay_source, files, tuple(warnings))


def gains_sampling(doc: object, where: str, frfs: Sequence[tuple[object, object]], *,
                   override: bool = False) -> TargetSampling | None:
    """The rate and delay a gains document was designed for, checked against the FRFs it is analysed on.

    Parameters
    ----------
    doc : Mapping
        The gains document (its ``sampling.fs_hz`` [Hz] and ``sampling.delay_samples`` [samples]).
    where : str
        Its file name, for messages.
    frfs : sequence of (name, Frf or None)
        The FRF files of the analysis.
    override : bool
        ``--fs-override``: an FRF recording another rate is a warning, not an error.

    Returns
    -------
    TargetSampling or None
        ``fs_source = "gains"``; None when the document has no readable rate (the analysis names that error).
    """
    import math
    from collections.abc import Mapping

    sec = doc.get("sampling") if isinstance(doc, Mapping) else None
    if not isinstance(sec, Mapping):
        return None

    def number(key: str):
        v = sec.get(key)
        v = v.get("value") if isinstance(v, Mapping) else v
        return v if isinstance(v, (int, float)) and not isinstance(v, bool) else None

    from ..control.discretize import FS_MAX_HZ, FS_MIN_HZ, MAX_DELAY_SAMPLES

    fs, delay = number("fs_hz"), number("delay_samples")
    if fs is None or not (math.isfinite(fs) and FS_MIN_HZ <= fs <= FS_MAX_HZ) or delay is None \
            or not (math.isfinite(delay) and 0 <= delay <= MAX_DELAY_SAMPLES) or int(delay) != delay:
        return None  # the document's own checks name the entry
    return target_sampling(float(fs), int(delay), frfs, default_fs=float(fs), override=override,
                           given_by=f"{where}'s sampling.fs_hz", given_source="gains")
