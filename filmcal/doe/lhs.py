"""Optimal Latin hypercube designs.

A random Latin hypercube with points at cell centres (drawn with
`pydoe.lhs`, ``criterion='center'``) is improved by the enhanced stochastic
evolutionary (ESE) algorithm of Jin, Chen & Sudjianto (2005), "An efficient
algorithm for constructing optimal design of computer experiments",
J. Stat. Plan. Inference 134, 268-287, minimising the Morris-Mitchell
criterion ``phi_p`` (p = 50). Every move exchanges two elements of one column,
so the design stays a Latin hypercube throughout.

Points sit at the cell centres ``(k + 0.5) / n`` (no jitter): on the integer
lattice of cell indices squared distances are exact integers, ``d_ij^-p`` comes
from a lookup table, and centred points give a larger minimum distance than
jittered ones.

Cost: an exchange of rows ``a`` and ``b`` in column ``k`` changes only the
distances from ``a`` and from ``b`` to the other rows, by ``+u_l`` and ``-u_l``
with ``u_l = (x_bk - x_ak)(x_bk + x_ak - 2 x_lk)``; the change of
``sum_{i<j} d_ij^-p`` is therefore O(n) per candidate exchange, and the ``J``
candidates of one ESE step are evaluated together as ``(J, n)`` arrays.
The pair sums are updated in O(n) per accepted exchange (a row that loses a
term far larger than what remains is summed afresh) and all of them after
every inner loop, which keeps rounding from accumulating while ``phi_p^p``
falls through many orders of magnitude.
"""
from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass
from numbers import Integral

import numpy as np
from pydoe import lhs

from filmcal.doe.metrics import P_DEFAULT, _as_sample

__all__ = ["OptimalLatinHypercube", "N_OUTER_DEFAULT"]

SeedLike = int | np.random.Generator | None

# Outer ESE iterations by default; for n = 100, d = 4 about 0.25 s of CPU
# time (figures: bench/doe_quality.py).
N_OUTER_DEFAULT = 30
# Largest squared lattice distance for which d2^(-p/2) is tabulated (32 MiB).
_TABLE_MAX = 1 << 22


def _check_count(name: str, value: object, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, Integral) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


class _InversePower:
    """Pair term ``d2^(-p/2)`` of ``phi_p^p`` as a function of squared distance.

    On the integer lattice the terms come from a table indexed by ``d2`` with
    the diagonal marked by ``d2 = 0``; otherwise they are computed, with the
    diagonal marked by ``d2 = inf``. Either marker maps to 0. Off the lattice
    ``d2`` is offset by ``1e-9`` (squared cell widths) so that points that
    coincide (possible only when every column is discrete) weigh heavily
    without making the sum infinite.
    """

    def __init__(self, p: float, lattice_max: int | None) -> None:
        self.half_p = p / 2.0
        self.table = None
        self.diagonal = np.inf
        if lattice_max is not None and lattice_max <= _TABLE_MAX:
            with np.errstate(divide="ignore"):
                self.table = np.arange(lattice_max + 1, dtype=float) ** -self.half_p
            self.table[0] = 0.0
            self.diagonal = 0

    def __call__(self, d2: np.ndarray) -> np.ndarray:
        if self.table is not None:
            return self.table.take(d2)
        return (d2 + 1e-9) ** -self.half_p


def _squared_distances(points: np.ndarray, diagonal: float) -> np.ndarray:
    """All squared Euclidean distances, with `diagonal` on the diagonal."""
    d2 = np.zeros((len(points), len(points)), dtype=points.dtype)
    for column in points.T:
        diff = column[:, None] - column[None, :]
        d2 += diff * diff
    np.fill_diagonal(d2, diagonal)
    return d2


@dataclass(frozen=True)
class _ESESettings:
    """Settings of one ESE run (see `OptimalLatinHypercube`)."""

    p: float
    n_outer: int
    n_inner: int
    n_candidates: int


class _PairSums:
    """The pair terms ``d_ij^-p`` of a design and their sums, kept up to date
    under exchanges of two elements of one column.

    Pairs of two rows before `n_fixed` are left out (they cannot change).
    """

    def __init__(self, points: np.ndarray, n_fixed: int, power: _InversePower) -> None:
        self.x = points.copy()
        self.power = power
        self.d2 = _squared_distances(self.x, power.diagonal)
        self.terms = power(self.d2)
        self.terms[:n_fixed, :n_fixed] = 0.0
        self.resum()

    def resum(self) -> None:
        """Sum all terms afresh."""
        self.row_sums = self.terms.sum(axis=1)
        self.total = self.row_sums.sum() / 2.0

    def changes(self, k: int, a: np.ndarray, b: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Change of the total for exchanging ``x[a_j, k]`` and ``x[b_j, k]``,
        for every ``j`` at once, with the new squared distances of rows a and b.

        Only distances from a and from b move: by ``+u`` and ``-u`` with
        ``u_l = (x_bk - x_ak)(x_bk + x_ak - 2 x_lk)``; the distance a-b stays.
        """
        column = self.x[:, k]
        xa, xb = column[a], column[b]
        u = (xb - xa)[:, None] * ((xb + xa)[:, None] - 2 * column[None, :])
        rows = np.arange(len(a))
        u[rows, a] = 0
        u[rows, b] = 0
        new_a = self.d2[a] + u
        new_b = self.d2[b] - u
        change = (self.power(new_a).sum(axis=1) + self.power(new_b).sum(axis=1)
                  - self.row_sums[a] - self.row_sums[b])
        return change, new_a, new_b

    def exchange(self, k: int, a: int, b: int, d2_a: np.ndarray, d2_b: np.ndarray) -> None:
        """Exchange ``x[a, k]`` and ``x[b, k]``, given the new distances of a and b."""
        x, d2, terms = self.x, self.d2, self.terms
        x[a, k], x[b, k] = x[b, k], x[a, k]
        term_a, term_b = self.power(d2_a), self.power(d2_b)
        removed = terms[a] + terms[b]
        self.row_sums += (term_a + term_b) - removed
        d2[a], d2[:, a], d2[b], d2[:, b] = d2_a, d2_a, d2_b, d2_b
        terms[a], terms[:, a], terms[b], terms[:, b] = term_a, term_a, term_b, term_b
        # A row that lost a term far larger than what remains is summed afresh:
        # the update would have cancelled its significant digits.
        lossy = np.flatnonzero(removed > 1e4 * self.row_sums)
        self.row_sums[lossy] = terms[lossy].sum(axis=1)
        self.row_sums[a], self.row_sums[b] = term_a.sum(), term_b.sum()
        self.total = self.row_sums.sum() / 2.0


def _ese(points: np.ndarray, n_fixed: int, power: _InversePower, settings: _ESESettings,
         rng: np.random.Generator) -> np.ndarray:
    """Minimise ``phi_p`` over exchanges within columns among rows ``n_fixed:``.

    Rows before `n_fixed` stay where they are. Each move proposes the best of
    `n_candidates` random exchanges in one column (columns in turn) and
    accepts it if ``phi_p`` rises by less than ``threshold * U(0, 1)``;
    the threshold follows `_next_threshold`. Returns the best arrangement.
    """
    n, d = points.shape
    movable = n - n_fixed
    sums = _PairSums(points, n_fixed, power)
    inv_p = 1.0 / settings.p
    phi = sums.total ** inv_p
    best_phi, best_x = phi, sums.x.copy()
    threshold = 0.005 * phi            # initial threshold of Jin et al. (2005)
    warming = True
    shape = (settings.n_inner, settings.n_candidates)
    step = 0
    for _ in range(settings.n_outer):
        previous_best = best_phi
        first = rng.integers(movable, size=shape)
        second = n_fixed + (first + rng.integers(1, movable, size=shape)) % movable
        first += n_fixed
        coins = rng.random(settings.n_inner)
        accepted = improved = 0
        for a, b, coin in zip(first, second, coins):
            k = step % d
            step += 1
            change, new_a, new_b = sums.changes(k, a, b)
            j = int(np.argmin(change))
            # The proposal's phi may be rough when it removes a dominant term;
            # the accepted state's phi is summed exactly.
            if max(sums.total + change[j], 0.0) ** inv_p - phi > threshold * coin:
                continue
            sums.exchange(k, a[j], b[j], new_a[j], new_b[j])
            phi = sums.total ** inv_p
            accepted += 1
            if phi < best_phi:
                best_phi, best_x = phi, sums.x.copy()
                improved += 1
        sums.resum()
        phi = sums.total ** inv_p
        threshold, warming = _next_threshold(threshold, warming, accepted / settings.n_inner,
                                             improved, accepted,
                                             best_phi < previous_best * (1.0 - 1e-9))
    return best_x


def _next_threshold(threshold: float, warming: bool, acceptance: float, improved: int,
                    accepted: int, improving: bool) -> tuple[float, bool]:
    """ESE threshold control (Jin et al. 2005, Sec. 4.2).

    While the best design improves, lower the threshold if many moves are
    accepted but not all improve, raise it if few are accepted. Otherwise
    explore: raise the threshold quickly until more than 80 % of moves are
    accepted, then lower it slowly until fewer than 10 % are.
    """
    if improving:
        if acceptance > 0.1 and improved < accepted:
            return threshold * 0.8, warming
        if acceptance > 0.1:
            return threshold, warming
        return threshold / 0.8, warming
    if warming and acceptance > 0.8:
        warming = False
    elif not warming and acceptance < 0.1:
        warming = True
    return (threshold / 0.7 if warming else threshold * 0.9), warming


def _cells_of(positions: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Cell indices of optimised positions, column by column.

    `cells` holds, per column, the cells in use; the row with the ``r``-th
    smallest position gets the ``r``-th smallest cell. Positions increase
    with the cell (strictly, except between cells of one discrete level,
    which are interchangeable), so this inverts the map from cells to
    positions.
    """
    out = np.empty(positions.shape, dtype=np.int64)
    for k in range(positions.shape[1]):
        out[np.argsort(positions[:, k], kind="stable"), k] = np.sort(cells[:, k])
    return out


class OptimalLatinHypercube:
    """Optimal Latin hypercube sampler in ``[0, 1)^d`` (ESE on ``phi_p``).

    Each call of `random` draws a cell-centred Latin hypercube and optimises
    it with the enhanced stochastic evolutionary algorithm of Jin, Chen &
    Sudjianto (2005) on the Morris-Mitchell criterion ``phi_p``. The result is
    a Latin hypercube: in every column the points ``(k + 0.5) / n``,
    ``k = 0 .. n-1``, each once.

    Parameters
    ----------
    d : int
        Dimension of the unit cube.
    p : float
        Exponent of ``phi_p`` in ``[1, 100]`` (default 50, which maximises
        the minimum distance and then thins the pairs at it).
    n_outer : int
        Outer ESE iterations (threshold updates). Cost grows linearly.
    n_inner : int, optional
        Moves per outer iteration; default ``min(2 n_e d / J, 100)`` with
        ``n_e = n(n-1)/2`` exchanges per column, as in Jin et al. (2005).
    n_candidates : int, optional
        Exchanges ``J`` tried per move (the best is proposed); default
        ``min(max(n_e / 5, 1), 100)``. Jin et al. cap ``J`` at 50; here the
        candidates are evaluated together, so more of them cost little next
        to the fixed cost of a move.
    n_levels : sequence of int or None, optional
        Per dimension, the number ``L`` of discrete levels the column will be
        mapped to (``None`` for a continuous column): ``u`` goes to level
        ``floor(u L)``, realised at the bin centre ``(level + 0.5) / L``. The
        optimiser measures distances as realised, so the mapped design is
        space-filling; the returned column is still Latin, the mapped one is
        not.
    seed : int or numpy.random.Generator, optional
        Seed of all random draws; the same seed gives the same designs, bit
        for bit. The engine keeps a copy so that `reset` starts over.

    Examples
    --------
    >>> engine = OptimalLatinHypercube(d=2, seed=0)
    >>> engine.random(5).shape
    (5, 2)
    """

    def __init__(self, d: int, *, p: float = P_DEFAULT, n_outer: int = N_OUTER_DEFAULT,
                 n_inner: int | None = None, n_candidates: int | None = None,
                 n_levels: Sequence[int | None] | None = None, seed: SeedLike = None) -> None:
        self.d = _check_count("d", d, 1)
        if isinstance(p, bool) or not isinstance(p, (Integral, float)) or not 1.0 <= p <= 100.0:
            raise ValueError(f"p must be a number in [1, 100], got {p!r}")
        self.p = float(p)
        self.n_outer = _check_count("n_outer", n_outer, 0)
        self.n_inner = None if n_inner is None else _check_count("n_inner", n_inner, 1)
        self.n_candidates = None if n_candidates is None else _check_count("n_candidates",
                                                                           n_candidates, 1)
        n_levels = [None] * self.d if n_levels is None else list(n_levels)
        if len(n_levels) != self.d:
            raise ValueError(f"n_levels must have d = {self.d} entries, got {len(n_levels)}")
        self.n_levels = tuple(None if count is None else _check_count("n_levels", count, 2)
                              for count in n_levels)
        if seed is not None and not isinstance(seed, (Integral, np.random.Generator)):
            raise ValueError(f"seed must be an int, a numpy Generator or None, got {seed!r}")
        self.seed = copy.deepcopy(seed)
        self.reset()

    def reset(self) -> OptimalLatinHypercube:
        """Restart the random stream from `seed`; return the engine."""
        self.rng = np.random.default_rng(copy.deepcopy(self.seed))
        return self

    def _settings(self, movable: int) -> _ESESettings:
        exchanges = movable * (movable - 1) // 2
        n_cand = self.n_candidates or min(max(exchanges // 5, 1), 100)
        n_inner = self.n_inner or max(min(2 * exchanges * self.d // n_cand, 100), 1)
        return _ESESettings(self.p, self.n_outer, n_inner, n_cand)

    def _positions(self, cells: np.ndarray, n: int) -> np.ndarray:
        """Coordinates of cells of width ``1/n`` as realised, in cell widths:
        the cell centre, or for a discrete column the centre of its level's bin."""
        positions = cells + 0.5
        for k, n_lev in enumerate(self.n_levels):
            if n_lev is not None:
                level = np.floor((cells[:, k] + 0.5) / n * n_lev)
                positions[:, k] = (level + 0.5) / n_lev * n
        return positions

    def random(self, n: int) -> np.ndarray:
        """Draw an optimised Latin hypercube of `n` points.

        Parameters
        ----------
        n : int
            Number of points, at least 2.

        Returns
        -------
        ndarray, shape (n, d)
            Points at cell centres ``(k + 0.5) / n`` in ``[0, 1)^d``.
        """
        n = _check_count("n", n, 2)
        start = lhs(self.d, samples=n, criterion="center", seed=self.rng)
        cells = np.rint(start * n - 0.5).astype(np.int64)
        continuous = all(n_lev is None for n_lev in self.n_levels)
        power = _InversePower(self.p, self.d * (n - 1) ** 2 if continuous else None)
        points = cells if power.table is not None else self._positions(cells, n)
        best = _ese(points, 0, power, self._settings(n), self.rng)
        return (_cells_of(best, cells) + 0.5) / n

    def augment(self, sample: np.ndarray, m: int) -> np.ndarray:
        """Add `m` points to an existing design, keeping it space-filling.

        With ``N = n + m`` the unit interval is cut into ``N`` cells per
        column. The new points take, in every column, distinct cells that no
        existing point occupies, at their centres (there are always at least
        ``m`` such cells; when there are more, an evenly spread subset is
        used). Their arrangement is then optimised by ESE on ``phi_p`` over
        the pairs that involve a new point, i.e. the new points keep as far
        from the existing ones and from each other as the cells allow
        (discrete columns measured as realised, see `n_levels`).

        Guarantee: the existing points are returned unchanged, first. If in
        every column the existing values lie at least ``1/N`` apart (true for
        any cell-centred Latin hypercube, such as `random` returns) the
        augmented design is an exact Latin hypercube on ``N`` cells;
        otherwise each column holds no two new points in one cell and no new
        point in a cell of an existing one.

        Parameters
        ----------
        sample : array_like, shape (n, d)
            Existing design in ``[0, 1]^d``, ``n >= 1``.
        m : int
            Number of points to add, at least 1.

        Returns
        -------
        ndarray, shape (n + m, d)
        """
        sample = _as_sample(sample, min_points=1)
        if sample.shape[1] != self.d:
            raise ValueError(f"sample must have d = {self.d} columns, got {sample.shape[1]}")
        if sample.min() < 0.0 or sample.max() > 1.0:
            raise ValueError("sample must lie in the unit cube [0, 1]^d")
        m = _check_count("m", m, 1)
        n_old = len(sample)
        total = n_old + m
        old_cells = np.clip(np.floor(sample * total).astype(np.int64), 0, total - 1)
        new_cells = np.empty((m, self.d), dtype=np.int64)
        for k in range(self.d):
            free = np.setdiff1d(np.arange(total), old_cells[:, k])
            chosen = free[((np.arange(m) + 0.5) * len(free) / m).astype(np.int64)]
            new_cells[:, k] = self.rng.permutation(chosen)
        points = np.vstack([sample * total, self._positions(new_cells, total)])
        if m >= 2:
            points = _ese(points, n_old, _InversePower(self.p, None), self._settings(m), self.rng)
        new_cells = _cells_of(points[n_old:], new_cells)
        return np.vstack([sample, (new_cells + 0.5) / total])
