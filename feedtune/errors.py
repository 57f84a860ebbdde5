"""Exceptions that carry a one-line, user-facing message and an exit code.

The command line turns every :class:`FeedtuneError` into one line on stderr and the exit code it carries:
2 for usage errors (bad options, unknown commands), 1 for data errors (bad files, failed fits, unstable
designs). Library users catch them like ordinary exceptions: :class:`DataError`, :class:`UsageError` and
:class:`DesignError` are also :class:`ValueError` s, as scipy's and numpy's errors about bad values are.

Library messages speak of parameters (``lpf_hz``, ``filters.notches``), not of command-line flags. An error about
a parameter names it in ``parameter``; the command line prints the message with each such name replaced by its
option (:func:`cli_message`, :data:`CLI_OPTIONS`), so the same error reads ``--lpf-hz`` there.

Examples
--------
>>> err = UsageError("beta must be >= 1, got 0.5", parameter="beta")
>>> isinstance(err, ValueError), err.parameter
(True, 'beta')
>>> cli_message(err)
'--beta must be >= 1, got 0.5'
>>> cli_message(UsageError("out.csv exists; pass force=True to overwrite", parameter="force"))
'out.csv exists; pass --force to overwrite'
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping


class FeedtuneError(Exception):
    """Base class: a problem the user can act on, described in one line.

    Parameters
    ----------
    *args
        The message (and, rarely, more arguments, as for :class:`Exception`).
    parameter : str or sequence of str, optional
        The library parameter(s) the message is about, spelled as in the message (``"lpf_hz"``,
        ``"filters.notches"``); the first is :attr:`parameter`, all are :attr:`parameters`.
    cli : str, optional
        The message as the command line prints it where its advice is a different step there (a command instead
        of a function), as for :class:`Notice`.
    """

    exit_code = 1

    def __init__(self, *args: object, parameter: str | Iterable[str] | None = None, cli: str | None = None) -> None:
        super().__init__(*args)
        names = (parameter,) if isinstance(parameter, str) else tuple(parameter or ())
        self.parameters: tuple[str, ...] = tuple(str(n) for n in names)
        self.parameter: str | None = self.parameters[0] if self.parameters else None
        self.cli = cli


class DataError(FeedtuneError, ValueError):
    """Input data are missing, malformed or unusable (exit code 1)."""

    exit_code = 1


class UsageError(FeedtuneError, ValueError):
    """An option or parameter has an invalid value (exit code 2)."""

    exit_code = 2


class DesignError(FeedtuneError, ValueError):
    """A design is unstable or violates the requested limits (exit code 1)."""

    exit_code = 1


class IllConditionedError(DataError):
    """A least-squares problem has no reliable solution (reason in the message)."""


class FeedtuneWarning(UserWarning):
    """A warning of feedtune's own: the command line prints it as one ``feedtune: warning: ...`` line."""


class FeedtuneNote(FeedtuneWarning):
    """Information the user should see once (a newer document version read): ``feedtune: note: ...``."""


class Notice(str):
    """A warning in the library's words: the text (a plain ``str`` everywhere) names parameters, as errors do, and
    the command line prints it with their options (:func:`cli_message`), or prints ``cli`` when its advice is a
    different step there (a command instead of a function).

    Examples
    --------
    >>> w = Notice("the steps dominate; use a lower cutoff_hz", parameter="cutoff_hz")
    >>> w.endswith("cutoff_hz"), cli_message(w)
    (True, 'the steps dominate; use a lower --lpf-hz')
    >>> cli_message(Notice("call remove_sampling(frf, fs, delay)", cli="run feedtune frf --remove-sampling N"))
    'run feedtune frf --remove-sampling N'
    """

    parameters: tuple[str, ...]
    cli: str | None

    def __new__(cls, text: str, *, parameter: str | Iterable[str] | None = None, cli: str | None = None) -> Notice:
        self = super().__new__(cls, text)
        self.parameters = (parameter,) if isinstance(parameter, str) else tuple(parameter or ())
        self.cli = cli
        return self


# ------------------------------------------------------------------------------ command-line spelling
CLI_OPTIONS: dict[str, str] = {
    "Kpx": "--kpx",
    "Kpv": "--kpv",
    "Kiv": "--kiv",
    "FilterPack.lpf_hz": "--lpf",
    "positions": "--x",
    "out_dir": "--out",
    "fit_ballscrew.lead_m_per_rad": "--lead",
    "read_log.mapping": "--map",
    "read_log.units": "--unit",
    "read_frf.scale": "--frf-scale",
    "read_frf.skip_rows": "--frf-skip-rows",
    "read_frf.auto_channel": "--frf-channel",
    "read_frf.columns": "--frf-map",
    "fit_prefilter.lead_m_per_rad": "--gains GAINS",
    "log_kinds": "--log-kind",
    "cutoff_hz": "--lpf-hz",
    "reversal_guard_s": "--reversal-guard",
    "lead_m_per_rad": "--lead",
    "period_s": "--period",
    "after_s": "--after",
    "drift_m_per_s": "--drift",
    "run_ropesnap.force": "--rope-force",
    "default_x_grid.n": "--x-points",
    "shift_s": "--shift",
    "force_n": "--rope-force",
    "v_band": "--friction-band",
    "xs": "--x",
    "fit_ballscrew.channels": "--channel",
    "band_hz": "--band",
    "read_frf.freq_var": "--mat-freq",
    "read_frf.channels": "--mat-channel",
    "read_log.skip_rows": "--skip-rows",
    "L": "--span",
    "PlateauSettings.min_duration": "--plateau-min-duration",
    "PlateauSettings.vel_tol": "--plateau-vel-tol",
    "PlateauSettings.acc_tol": "--plateau-acc-tol",
    "PlateauSettings.min_speed": "--min-speed",
    "units": "--unit",
}
"""How the command line spells a library parameter where it is not ``--`` plus the name with dashes for
underscores (``lpf_hz`` -> ``--lpf-hz``). Keys are the parameters errors carry, qualified by their owner where one
name has two spellings (``FilterPack.lpf_hz`` is ``--lpf``, ``fit_prefilter``'s ``lpf_hz`` is ``--lpf-hz``)."""


def option_name(parameter: str, options: Mapping[str, str] | None = None) -> str:
    """The command-line option of a library parameter (:data:`CLI_OPTIONS`, else ``--name-with-dashes``).

    Examples
    --------
    >>> option_name("crossover_hz"), option_name("FilterPack.lpf_hz")
    ('--crossover-hz', '--lpf')
    """
    table = CLI_OPTIONS if options is None else {**CLI_OPTIONS, **options}
    word = parameter.rsplit(".", 1)[-1]
    for key in (parameter, word):
        if key in table:
            return table[key]
    return "--" + word.lower().replace("_", "-")


def cli_message(exc: BaseException | str, options: Mapping[str, str] | None = None) -> str:
    """The message of ``exc`` as the command line prints it, each of its :attr:`~FeedtuneError.parameters` named by
    its option (:func:`option_name`).

    A parameter ``owner.name`` appears in the message as ``name``. Where the message writes it as a keyword,
    ``name=`` (``name one with error= or position=``, ``identify it with law=stribeck``), only those occurrences
    are replaced (``--error``, ``--law stribeck``; a flag's ``name=True`` is the bare option, ``pass force=True``
    -> ``pass --force``), so the same word can stay plain English elsewhere; otherwise every whole-word occurrence
    is.

    Parameters
    ----------
    exc : BaseException or str
        Usually a :class:`FeedtuneError` or a :class:`Notice` (whose ``cli`` text, when it has one, is returned as
        it is); other exceptions and strings give ``str(exc)``.
    options : dict, optional
        Spellings that override :data:`CLI_OPTIONS`.
    """
    if getattr(exc, "cli", None):
        return str(exc.cli)
    text = str(exc)
    names = getattr(exc, "parameters", ()) or ()
    for name in sorted(names, key=lambda n: len(n.rsplit(".", 1)[-1]), reverse=True):
        word = re.escape(name.rsplit(".", 1)[-1])
        option = option_name(name, options).replace("\\", r"\\")
        keyword = rf"(?<![\w.\-/\\]){word}="
        if re.search(keyword, text):
            text = re.sub(keyword + r"(?:True)?(?=[\s,.;:)\]]|$)", option, text)  # force=True -> --force
            text = re.sub(keyword, option + " ", text)
        else:
            text = re.sub(rf"(?<![\w.\-/\\]){word}(?![\w\-/\\])", option, text)  # not inside a path
    return text
