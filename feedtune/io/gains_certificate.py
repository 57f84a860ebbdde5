"""The ``[certificate]`` of a gains document: what it holds and the digests that tie it to its gains and its FRFs.

A design or tune certified on measured FRFs carries its certificate in the gains file
(:func:`feedtune.workflows.deliver.deliver` writes it; :mod:`feedtune.machines.certificate` computes it). Two digests
make it checkable later without the FRFs:

* ``gains_sha256``: SHA-256 of the certified sections (:func:`certified_sections`: every section except those
  listed in :data:`UNCERTIFIED_SECTIONS`, which do not enter the feedback loop the certificate judges), each written
  as canonical JSON (keys sorted, no spaces, floats as Python ``repr``); ``sections_sha256`` holds one digest per
  section, so that a reader can name the section edited after certification. A gains file read from TOML or from its
  JSON twin gives the same digests (both parse to the same values).
* per FRF ``sha256``: the SHA-256 of the FRF file's bytes when it came from a file (``identity = "file"``), or of
  its arrays when it came from memory (``identity = "arrays"``, e.g. the demos' twin FRFs): frequencies, channel names
  and responses as little-endian float64/complex128 (:func:`frf_arrays_sha256`).

:func:`read_certificate` says whether a document's certificate still holds for its gains: ``valid``, ``edited``
(which sections changed), ``undigested`` (written before the digests existed: it cannot tell) or ``absent``.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..errors import DataError

UNCERTIFIED_SECTIONS = ("schema", "created_by", "law", "analysis", "certificate", "prefilter",
                        "friction_feedforward", "shaper")
"""Sections outside the gains digest: the schema string, the writer's version, the law's execution text (rewritten
when an optional section is added), information-only figures, the certificate itself, and the trajectory pre-filter,
friction feedforward and input shaper (they act on the reference, outside the feedback loop the certificate judges:
adding them with ``feedtune prefilter``, ``--friction`` or ``feedtune design shaper`` keeps a certificate valid)."""

CERTIFICATE_FORMAT = "feedtune.certificate/1"
"""The ``format`` of a ``[certificate]`` section with digests (older ones, written by ``tune`` before them, have
none)."""


def _canonical(value) -> bytes:
    """Canonical JSON bytes of a document value: keys sorted, no spaces, numpy converted, floats as ``repr``."""
    from .document import _json_safe, _plain

    return json.dumps(_json_safe(_plain(value, "")), sort_keys=True, separators=(",", ":"), allow_nan=False,
                      ensure_ascii=False).encode("utf-8")


def certified_sections(doc: Mapping) -> list[str]:
    """The sections of ``doc`` the gains digest covers, in the document's order."""
    return [k for k in doc if k not in UNCERTIFIED_SECTIONS]


def section_digests(doc: Mapping) -> dict[str, str]:
    """``{section: sha256 hex}`` of every certified section (module docstring)."""
    return {k: hashlib.sha256(_canonical(doc[k])).hexdigest() for k in certified_sections(doc)}


def gains_sha256(doc: Mapping) -> str:
    """SHA-256 (hex) of the certified sections of a gains document together (module docstring)."""
    digests = section_digests(doc)
    return hashlib.sha256(_canonical(dict(sorted(digests.items())))).hexdigest()


def file_sha256(path: str | os.PathLike[str]) -> str:
    """SHA-256 (hex) of a file's bytes; DataError naming the file when it cannot be read."""
    from ._table import read_bytes

    return hashlib.sha256(read_bytes(path)).hexdigest()


def frf_arrays_sha256(frf) -> str:
    """SHA-256 (hex) of an FRF's arrays: a version tag, the frequencies [Hz] as little-endian float64, the channel
    names ``OUT/IN`` (UTF-8, newline-separated) and the responses as little-endian complex128 in channel order.
    Coherence, units and metadata are not included (they do not enter a certificate's figures)."""
    h = hashlib.sha256(b"feedtune.frf-arrays/1\n")
    h.update(np.ascontiguousarray(frf.freq_hz, dtype="<f8").tobytes())
    h.update(("\n".join(frf.channels) + "\n").encode("utf-8"))
    for ch in frf.channels:
        h.update(np.ascontiguousarray(frf.channel(ch), dtype="<c16").tobytes())
    return h.hexdigest()


def short(sha256: str | None) -> str:
    """The first 12 hex digits of a digest (as printed)."""
    return "-" if not sha256 else str(sha256)[:12]


@dataclass(frozen=True)
class StoredCertificate:
    """A gains document's ``[certificate]`` and whether it still holds for the document's gains.

    Attributes
    ----------
    section : dict
        The ``[certificate]`` as stored (``limits``, ``frfs``, ``worst``, the digests, ``date``, ``made_by``).
    status : str
        ``valid`` (the gains digest matches), ``edited`` (it does not: :attr:`changed` names the sections),
        ``undigested`` (a certificate without digests: it cannot say whether the gains were edited) or ``absent``.
    changed : tuple of str
        The certified sections whose digest differs (``edited``), or that were added or removed.
    where : str
        The file's name for messages.
    """

    section: dict
    status: str
    changed: tuple[str, ...] = ()
    where: str = "gains file"

    @property
    def valid(self) -> bool:
        """The certificate holds for these gains."""
        return self.status == "valid"

    @property
    def frfs(self) -> list[dict]:
        """The FRF entries (``frf``, ``sha256``, ``identity``, figures...)."""
        return list(self.section.get("frfs") or [])

    def basis(self) -> str:
        """``certified on a.csv (sha256 1a2b3c4d5e6f), b.csv (sha256 ...) on 2025-01-31 under textbook limits``."""
        frfs = ", ".join(f"{e.get('frf', '?')} (sha256 {short(e.get('sha256'))}"
                         + (", its arrays" if e.get("identity") == "arrays" else "") + ")" for e in self.frfs)
        date = self.section.get("date")
        profile = (self.section.get("limits") or {}).get("profile", "?")
        return f"certified on {frfs or 'no FRF'}" + (f" on {date}" if date else "") + f" under {profile} limits"

    def problem(self) -> str | None:
        """Why the certificate does not hold (one line naming the file), None when it does."""
        if self.status == "valid":
            return None
        if self.status == "absent":
            return f"{self.where}: not certified on a measured FRF"
        if self.status == "undigested":
            return (f"{self.where}: its [certificate] has no gains digest (written before feedtune recorded one), so "
                    "it cannot show that the gains are the ones it certified; it is not used")
        return (f"{self.where}: the gains were edited after they were certified ({', '.join(self.changed)} changed "
                f"since they were {self.basis()}); the certificate no longer holds and is not used")


def read_certificate(doc: Mapping, where: str = "gains file") -> StoredCertificate:
    """The ``[certificate]`` of a gains document and whether it still holds for its gains (module docstring).

    Raises
    ------
    DataError
        A ``[certificate]`` that is not a table, or whose digests or FRF entries are malformed.
    """
    sec = doc.get("certificate")
    if sec is None:
        return StoredCertificate({}, "absent", where=where)
    if not isinstance(sec, Mapping):
        raise DataError(f"{where}: [certificate] must be a table")
    sec = dict(sec)
    stored = sec.get("sections_sha256")
    if sec.get("gains_sha256") is None or not isinstance(stored, Mapping):
        return StoredCertificate(sec, "undigested", where=where)
    frfs = sec.get("frfs")
    if not isinstance(frfs, list) or not frfs or not all(isinstance(e, Mapping) and "frf" in e for e in frfs):
        raise DataError(f"{where}: certificate.frfs must be a non-empty list of tables, each with its frf name")
    now = section_digests(doc)
    changed = tuple(sorted({k for k in set(now) | set(stored) if now.get(k) != stored.get(k)}))
    if changed or gains_sha256(doc) != sec["gains_sha256"]:
        return StoredCertificate(sec, "edited", changed or ("the gains digest",), where)
    return StoredCertificate(sec, "valid", where=where)


__all__ = [
    "CERTIFICATE_FORMAT",
    "UNCERTIFIED_SECTIONS",
    "StoredCertificate",
    "certified_sections",
    "file_sha256",
    "frf_arrays_sha256",
    "gains_sha256",
    "read_certificate",
    "section_digests",
    "short",
]
