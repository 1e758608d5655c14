"""How a target's row reads its verdict (shared by every part of the bench's report)."""
from __future__ import annotations


def verdict(measured: float, ok: bool) -> str:
    """"met" or "missed" by `ok`; "not measured" when the figure is NaN."""
    return "not measured" if measured != measured else ("met" if ok else "missed")
