"""A sweep specification: which scene keys vary, and how (a list, a grid or a distribution).

    KEY=[a,b,...]            the listed values
    KEY=linspace(a,b,n)      n values evenly spaced from a to b
    KEY=logspace(a,b,n)      n values from 10^a to 10^b, evenly spaced in the exponent
    KEY=uniform(a,b)         random draws (with --random N), uniform on [a, b)
    KEY=normal(mu,sigma)     normal draws
    KEY=lognormal(mu,sigma)  exp of normal(mu, sigma) draws

KEY is any scene key, an element counted from 1 (`initial.u[2]` is omega20). Several keys
make a full grid; with `random` the cases are drawn instead, each key from its distribution
(a list or grid key then draws uniformly from its values). Every error names the key.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from ..errors import SceneError, excerpt
from ..scene import Scene, check_values, parse_override, split_key

GRIDS = ("linspace", "logspace")
DISTRIBUTIONS = ("uniform", "normal", "lognormal")
CALL = re.compile(r"^\s*(?P<name>[a-z]+)\s*\((?P<args>[^()]*)\)\s*$")
MAX_CASES = 10_000_000  # a sweep larger than this is a typo, not a study
DRAW_BLOCK = 100_000  # random cases drawn at a time (each axis's draws of a block: 0.8 MB)


@dataclass(frozen=True)
class Axis:
    """One varied key: its values (list or grid) or its distribution (name, parameters)."""

    key: str
    values: tuple[Any, ...] = ()
    distribution: str = ""
    parameters: tuple[float, ...] = ()

    def describe(self) -> str:
        if self.distribution:
            return f"{self.key}={self.distribution}({', '.join(f'{p:g}' for p in self.parameters)})"
        return f"{self.key}={list(self.values)}"

    def draw(self, rng: np.random.Generator, count: int) -> np.ndarray:
        """`count` draws: the values of a distribution, or the positions in `values` of a
        list's (drawn uniformly)."""
        if self.distribution == "uniform":
            lo, hi = self.parameters
            return rng.uniform(lo, hi, count)
        if self.distribution == "normal":
            return rng.normal(*self.parameters, count)
        if self.distribution == "lognormal":
            return rng.lognormal(*self.parameters, count)
        return rng.integers(0, len(self.values), count)

    def taken(self, drawn: np.ndarray) -> list[Any]:
        """Drawn values (`draw`) as the cases hold them: floats, or the list's values."""
        return drawn.tolist() if self.distribution else [self.values[i] for i in drawn.tolist()]


def parse_axis(text: str) -> Axis:
    """One `KEY=SPEC` of `--vary`."""
    if "=" not in text:
        raise SceneError("--vary", f"expected KEY=SPEC, got {excerpt(text)}")
    key, spec = (part.strip() for part in text.split("=", 1))
    split_key(key)  # an unknown key or a bad index ends here, named
    call = CALL.match(spec)
    if call is None:
        _, value = parse_override(f"{key}={spec}")
        if not isinstance(value, list) or not value:
            raise SceneError(key, f"expected a list [a, b, ...], a grid linspace(a,b,n) | logspace(a,b,n) "
                                  f"or a distribution {' | '.join(d + '(...)' for d in DISTRIBUTIONS)}, got {excerpt(spec)}")
        return Axis(key, tuple(value))
    name, args = call["name"], call["args"]
    try:
        numbers = [float(a) for a in args.split(",")]
    except ValueError:
        raise SceneError(key, f"{name}(...) takes numbers, got {excerpt(args)}") from None
    if not all(np.isfinite(numbers)):
        raise SceneError(key, f"{name}(...) takes finite numbers, got {excerpt(args)}")
    if name in GRIDS:
        if len(numbers) != 3 or not float(numbers[2]).is_integer():
            raise SceneError(key, f"{name}(a,b,n) takes two numbers and a whole count, got {excerpt(spec)}")
        count = int(numbers[2])
        if count < 1:
            raise SceneError(key, f"{name}(a,b,n) needs a count n of at least 1, got {count}")
        if count > MAX_CASES:  # before the grid is made: 1e9 values would fill the memory
            raise SceneError(key, f"{name}(a,b,n): n = {count} values, more than the limit of {MAX_CASES} "
                                  "cases in one sweep")
        grid = np.linspace if name == "linspace" else np.logspace
        return Axis(key, tuple(grid(numbers[0], numbers[1], count).tolist()))
    if name in DISTRIBUTIONS:
        if len(numbers) != 2:
            raise SceneError(key, f"{name}(a,b) takes two numbers, got {excerpt(spec)}")
        if name == "uniform" and not numbers[0] < numbers[1]:
            raise SceneError(key, f"uniform(a,b) needs a < b, got {excerpt(spec)}")
        if name != "uniform" and numbers[1] < 0:
            raise SceneError(key, f"{name}(mu,sigma) needs sigma >= 0, got {excerpt(spec)}")
        return Axis(key, distribution=name, parameters=tuple(numbers))
    raise SceneError(key, f"unknown range {excerpt(name)}: use linspace, logspace, "
                          f"{', '.join(DISTRIBUTIONS)} or a list [a, b, ...]")


def _vary_items(vary: Any) -> list[tuple[str | None, Any]]:
    """`vary` as (KEY, SPEC) pairs, or (None, "KEY=SPEC") for --vary strings; anything else
    is refused in one line that says how to write it."""
    how = ("expected vary={KEY: SPEC} (SPEC a list of values, one value, or a string such as "
           "'linspace(-0.5,-0.1,5)') or a list of 'KEY=SPEC' strings")
    if isinstance(vary, Mapping):
        bad = next((k for k in vary if not isinstance(k, str)), None)
        if bad is not None:
            raise SceneError("vary", f"a key must be a scene key as a string, got {excerpt(bad)}; {how}")
        return list(vary.items())
    if isinstance(vary, (list, tuple)) and all(isinstance(v, str) for v in vary):
        return [(None, v) for v in vary]
    raise SceneError("vary", f"{how}, got {excerpt(vary)}")


@dataclass(frozen=True)
class SweepSpec:
    """The varied keys and how the cases are made from them."""

    axes: tuple[Axis, ...]
    random: int = 0  # 0: the full grid; N: N random draws
    seed: int = 0
    _drawn: dict[int, list[np.ndarray]] = field(default_factory=dict, compare=False, repr=False, hash=False)

    @classmethod
    def from_vary(cls, vary: Mapping[str, Any] | list[str], random: int = 0, seed: int = 0) -> "SweepSpec":
        """From `--vary` strings, or a mapping KEY -> SPEC (a string, a list of values, or one
        value: a list of one)."""
        items = _vary_items(vary)
        axes = []
        for key, spec in items:
            if key is None:
                axes.append(parse_axis(spec))
            elif isinstance(spec, str):
                axes.append(parse_axis(f"{key}={spec}"))
            else:
                values = np.asarray(spec).tolist() if hasattr(spec, "tolist") else spec
                values = list(values) if isinstance(values, (list, tuple, range)) else [values]
                if not values:
                    raise SceneError(key, "no values to vary over")
                split_key(key)
                axes.append(Axis(key, tuple(values)))
        if not axes:
            raise SceneError("--vary", "give at least one KEY=SPEC to vary")
        keys = [a.key for a in axes]
        if len(set(keys)) != len(keys):
            raise SceneError(next(k for k in keys if keys.count(k) > 1), "is varied twice")
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise SceneError("--seed", f"expected a whole number >= 0 (numpy's generators take no other), "
                                       f"got {excerpt(seed)}")
        if isinstance(random, bool) or not isinstance(random, (int, np.integer)) or random < 0:
            raise SceneError("--random", f"expected a number of cases >= 1, got {excerpt(random)}")
        if not random and any(a.distribution for a in axes):
            key = next(a.key for a in axes if a.distribution)
            raise SceneError(key, "a distribution needs --random N (how many cases to draw)")
        spec = cls(tuple(axes), int(random), int(seed))
        if spec.count() > MAX_CASES:
            raise SceneError("--vary", f"{spec.count()} cases, more than {MAX_CASES}")
        return spec

    def count(self) -> int:
        return self.random or int(np.prod([len(a.values) for a in self.axes]))

    def cases(self) -> list[dict[str, Any]]:
        """Every case as overrides {KEY: value}, in a fixed order (case i is row i)."""
        return self.cases_at(np.arange(self.count()))

    def cases_at(self, indices: np.ndarray) -> list[dict[str, Any]]:
        """Cases `indices` (ascending) as overrides {KEY: value}: made when asked for, so that a
        sweep holds the cases of its chunks in flight only, never all of them."""
        keys = [a.key for a in self.axes]
        indices = np.asarray(indices, dtype=np.int64)
        if self.random:
            columns: list[list[Any]] = [[] for _ in self.axes]
            blocks = indices // DRAW_BLOCK
            for block in np.unique(blocks):
                drawn = self._block(int(block))
                rows = indices[blocks == block] - block * DRAW_BLOCK
                for column, axis, values in zip(columns, self.axes, drawn):
                    column.extend(axis.taken(values[rows]))
        else:
            places = np.unravel_index(indices, [len(a.values) for a in self.axes])  # itertools.product's order
            columns = [[a.values[i] for i in place.tolist()] for a, place in zip(self.axes, places)]
        if len(keys) == 1:  # the common case, made without zip: 1e5 cases in a few ms
            return [{keys[0]: value} for value in columns[0]]
        return [dict(zip(keys, row)) for row in zip(*columns)]

    def column(self, key: str) -> list[Any] | np.ndarray:
        """Every case's value of `key`, in case order (made a block of draws at a time; an
        array of a distribution's draws)."""
        axis = next(k for k, a in enumerate(self.axes) if a.key == key)
        if not self.random:
            places = np.unravel_index(np.arange(self.count()), [len(a.values) for a in self.axes])[axis]
            return [self.axes[axis].values[i] for i in places.tolist()]
        blocks = [self._block(block)[axis] for block in range(-(-self.random // DRAW_BLOCK))]
        if self.axes[axis].distribution:
            return np.concatenate(blocks)
        return [value for drawn in blocks for value in self.axes[axis].taken(drawn)]

    def _block(self, block: int) -> list[np.ndarray]:
        """The draws of cases block * DRAW_BLOCK onwards, each axis's in turn: the first block
        from the seed alone (a sweep of up to DRAW_BLOCK cases draws as it always did), each
        other from (seed, block), so that any block is made without the ones before it."""
        cached = self._drawn.get(block)
        if cached is None:
            rng = np.random.default_rng(self.seed if block == 0 else [self.seed, block])
            count = min(DRAW_BLOCK, self.random - block * DRAW_BLOCK)
            cached = [a.draw(rng, count) for a in self.axes]
            self._drawn.clear()  # one block kept: the chunks go through the blocks in order
            self._drawn[block] = cached
        return cached

    def check(self, scene: Scene) -> None:
        """Refuse, naming the key, an index out of range for `scene` and any value that no
        scene could take (a negative mass, a word for a number, a drawn Poisson ratio of 0.7).
        Values that are bad only together (a yield strength above the modulus) become rows.
        Drawn numbers are checked by their smallest and largest in each block of draws (a
        key's own check is a range); the values of a list or grid are checked as listed."""
        links_vary = any(a.key == "chain.links" for a in self.axes)
        first = self.cases_at(np.arange(min(1, self.count())))
        blocks = -(-self.random // DRAW_BLOCK)
        ranges = [(np.inf, -np.inf)] * len(self.axes)  # each drawn axis's smallest and largest
        for block in range(blocks):
            drawn = self._block(block)
            ranges = [(min(lo, d.min().item()), max(hi, d.max().item())) if a.distribution else (lo, hi)
                      for (lo, hi), d, a in zip(ranges, drawn, self.axes)]
        for axis in self.axes:
            try:  # the key (and its index) fits this scene
                scene.replace({axis.key: first[0][axis.key]} if first else {})
            except SceneError as exc:
                if exc.key == axis.key:
                    raise
                # another key named: a combination with the scene's other values, left to the rows
            if links_vary and isinstance(axis.values[0] if axis.values else None, list):
                continue  # a per-link list is checked against its case's own link count
            try:
                if not axis.distribution:
                    check_values(axis.key, axis.values, scene.n)
                    continue
                low, high = ranges[self.axes.index(axis)]
                try:
                    check_values(axis.key, [low, high], scene.n)
                except SceneError:  # the first value refused, in case order
                    for block in range(blocks):
                        check_values(axis.key, self._block(block)[self.axes.index(axis)].tolist(), scene.n)
            except SceneError as exc:
                drawn = " (drawn from the distribution: narrow it or choose another)" if axis.distribution else ""
                raise SceneError(exc.key, str(exc).split(": ", 1)[-1] + drawn) from None

    def describe(self) -> str:
        text = " ".join(f"--vary {a.describe()}" for a in self.axes)
        return text + (f" --random {self.random} --seed {self.seed}" if self.random else "")
