"""The C engine's records as Python reads them: the mirrors of tally.h's structs.

`EngineSession` (session.py) reads the run's switch records (`SwitchRecord`, ig_segment) and
its two summaries (`Tallied`, ig_summary) straight from the C memory, by layouts made once per
session from cffi's view of the structs (`record_layout`, `record_dtype`, `summary_layout`);
`TallyRecords` keeps the summaries' bytes until a summary is read.
"""
from __future__ import annotations

import struct
from typing import Any, NamedTuple

import numpy as np


class SwitchRecord(NamedTuple):
    """One switch record of a run (tally.h's ig_segment, but its parameters): point `point`'s
    segment ended at `t` at the switch `event` began, and its switch did `act`, from
    (state, slip) to (next_state, next_slip). A switch writes one record per point whose switch
    acted, in point order; the records of one switch share t, sample and event."""

    t: float  # the switch's time, s
    sample: int  # index of the sample at t in the run's samples (the start is sample 0)
    state: int  # the point's machine state before the switch
    slip: float  # its stick-slip state before it
    event: int  # the model event that began the switch
    act: int  # MODEL_ACT_* bits of the point's switch
    next_state: int
    next_slip: float
    delta_max: float  # the point's impact record after the switch
    P_max: float
    delta_r: float
    R_res: float
    point: int  # the point: k for joint k, links for the tip


class Tallied(NamedTuple):
    """A summary as the C engine tallied it during the run (tally.h's ig_summary, field
    for field): over the whole run, or over its first impact. NaN where there is nothing to
    report (t_impact, t_sustained). The reference engine's summaries are made the same way
    from its samples."""

    T0: float
    Tf: float
    delta_T: float
    delta_max: float
    delta_r: float
    P_max: float
    R_res: float
    t_contact: float
    t_impact: float
    t_sustained: float
    t_final: float
    W_normal: float
    W_friction: float
    W_gravity: float
    residual: float
    n_switches: int
    n_stick_slip: int
    impacts: int  # at every point
    point_impacts: tuple[int, ...]  # at each point, by its number 0..n (0 a free chain's base; a pinned chain's pivot: 0)
    first_point: int  # the first impact's point: 0 the base, k for joint k, n for the tip; none: 0 (pinned), -1 (free)
    v_n0: float  # the first impact's impulses and coefficients (COEFFICIENTS, its point's own), NaN until it ended
    P_c: float
    P_r: float
    P_t: float
    e_N: float
    e_P: float
    e_E: float
    friction_share: float
    y_final: tuple[float, ...]  # q, u, then the works and the impulses


class SummaryLayout(NamedTuple):
    """How the C engine's ig_summary record reads, made once per session from its cffi layout."""

    record: Any  # struct.Struct: every field as a Python value, in Tallied's order
    dtype: np.dtype  # the same record as a numpy structured dtype
    budget: Any  # struct.Struct: the energy budget's fields alone, in their order
    lengths: tuple[int | None, ...]  # each field's element count (an array's), None for a scalar

    def tallied(self, values: tuple) -> Tallied:
        """The record's values (`record`'s, flat) as a Tallied, an array field as a tuple."""
        fields, at = [], 0
        for length in self.lengths:
            fields.append(values[at] if length is None else values[at:at + length])
            at += 1 if length is None else length
        return Tallied._make(fields)


class TallyRecords:
    """The C engine's two summaries (the run's, its first impact's) as the bytes of their C
    records, each made a `Tallied` when first indexed (a summary reads one of them; a sweep
    reads one's bytes and its energy budget, and makes no `Tallied`). Pickled as the tuple
    of both."""

    __slots__ = ("_layout", "_raw", "_made")

    def __init__(self, layout: SummaryLayout, raw: bytes):
        self._layout, self._raw, self._made = layout, raw, [None, None]

    @property
    def dtype(self) -> np.dtype:
        return self._layout.dtype

    def raw(self, k: int) -> bytes:
        """Summary k as the bytes of its C record (`dtype`)."""
        size = self._layout.record.size
        return self._raw[k * size:(k + 1) * size]

    def budget(self, k: int) -> tuple[float, ...]:
        """The energy budget's fields of summary k (without making its `Tallied`: a sweep's
        warnings read nothing else of it)."""
        return self._layout.budget.unpack_from(self._raw, k * self._layout.record.size)

    def __getitem__(self, k: int) -> Tallied:
        made = self._made[k]
        if made is None:
            record = self._layout.record
            made = self._made[k] = self._layout.tallied(record.unpack_from(self._raw, k * record.size))
        return made

    def __len__(self) -> int:
        return 2

    def __reduce__(self):
        return tuple, ((self[0], self[1]),)


_CODES = {("double", 8): "d", ("int", 4): "i", ("long", 8): "q", ("long", 4): "i"}  # C scalar -> struct code


def _fields(ffi, ctype: str, skip: tuple[str, ...] = ()):
    """(name, struct code, element count or None for a scalar, offset) of each field of a
    C struct of doubles, integers and arrays of them, but the `skip` fields."""
    for name, f in ffi.typeof(ctype).fields:
        if name in skip:
            continue
        item = f.type.item if f.type.kind == "array" else f.type
        yield name, _CODES[item.cname, ffi.sizeof(item)], f.type.length if f.type.kind == "array" else None, f.offset


def record_layout(ffi, ctype: str, skip: tuple[str, ...] = ()) -> str:
    """The struct-module format of a C struct of doubles, integers and arrays of them (its
    `skip` fields passed over as pad bytes), laid out as the compiler laid it out: Python
    values of a whole record in one call, cheaper than a numpy record's."""
    layout, at = "", 0
    for name, code, count, offset in _fields(ffi, ctype, skip):
        layout += "x" * (offset - at) + code * (count or 1)
        at = offset + struct.calcsize(code) * (count or 1)
    return layout + "x" * (ffi.sizeof(ctype) - at)


def record_dtype(ffi, ctype: str) -> np.dtype:
    """The same struct as a numpy structured dtype: many records' bytes joined are one array
    (a sweep's chunk of summaries), with no Python value per field."""
    names, formats, offsets = [], [], []
    for name, code, count, offset in _fields(ffi, ctype):
        names.append(name)
        formats.append((code, (count,)) if count is not None else code)
        offsets.append(offset)
    return np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": ffi.sizeof(ctype)})


def switch_record_layout(ffi) -> struct.Struct:
    """How an ig_segment record reads as a `SwitchRecord` (its parameters passed over): the
    fields in SwitchRecord's order, checked here once per session."""
    names = tuple(name for name, _ in ffi.typeof("ig_segment").fields if name != "params")
    if names != SwitchRecord._fields:
        raise AssertionError(f"records.SwitchRecord does not mirror tally.h's ig_segment: {names}")
    return struct.Struct("=" + record_layout(ffi, "ig_segment", ("params",)))


def summary_layout(ffi, budget: tuple[str, ...]) -> SummaryLayout:
    """How an ig_summary record reads: as Python values in Tallied's order (which mirrors the
    C struct's, y_final last: checked here, once per session; its arrays as tuples), as a numpy
    dtype, and its energy budget (the `budget` fields, in Tallied's order) alone."""
    fields = ffi.typeof("ig_summary").fields
    if tuple(name for name, _ in fields) != Tallied._fields or fields[-1][1].type.kind != "array":
        raise AssertionError(f"records.Tallied does not mirror tally.h's ig_summary: {fields}")
    if [name for name in Tallied._fields if name in budget] != list(budget):
        raise AssertionError(f"the energy budget {budget} is not in ig_summary's order")
    others = tuple(name for name in Tallied._fields if name not in budget)
    lengths = tuple(count for _, _, count, _ in _fields(ffi, "ig_summary"))
    return SummaryLayout(struct.Struct("=" + record_layout(ffi, "ig_summary")), record_dtype(ffi, "ig_summary"),
                         struct.Struct("=" + record_layout(ffi, "ig_summary", others)), lengths)
