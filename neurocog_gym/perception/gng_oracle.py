"""A slow, plain NumPy DD-GNG: the test oracle for the numba kernels.

Same semantics and same random stream as :mod:`neurocog_gym.perception._gng_kernels`
(see that module's docstring), written the obvious way: a dense age matrix instead of
neighbour lists, a full distance sort instead of a grid, per-input decay of every error and
utility instead of lazy scales, Python integers for SplitMix64. Only for tests on small
inputs; never used by the environment.
"""

from __future__ import annotations

import numpy as np

from neurocog_gym.perception.gng import DDGNGParams, _check_boxes, _check_points

__all__ = ["DDGNGOracle"]

_MASK = (1 << 64) - 1
_GOLDEN = 0x9E3779B97F4A7C15
_MIX1 = 0xBF58476D1CE4E5B9
_MIX2 = 0x94D049BB133111EB


class DDGNGOracle:
    """Reference DD-GNG (``attention=True``) or GNG (``attention=False``).

    Args:
        seed: seed of the SplitMix64 stream (same as :class:`~neurocog_gym.perception.DDGNG`).
        params: parameters; ``None`` means Table 2 defaults.
        attention: use attention boxes (DD-GNG) or ignore them (GNG).
    """

    def __init__(
        self, seed: int = 0, params: DDGNGParams | None = None, attention: bool = True
    ) -> None:
        self.p = params if params is not None else DDGNGParams()
        self.attention = attention
        m = self.p.max_nodes
        self.state = int(seed) & _MASK
        self.pos = np.zeros((m, 3))
        self.E = np.zeros(m)
        self.U = np.zeros(m)
        self.delta = np.ones(m)
        self.alive = np.zeros(m, dtype=bool)
        self.age = np.full((m, m), -1, dtype=np.int64)  # -1: no edge
        self.t = 0
        self.boxes = np.zeros((0, 2, 3))
        self.res: list[np.ndarray] = []

    # ---- random numbers (SplitMix64) ---------------------------------------------------
    def _next(self) -> int:
        self.state = (self.state + _GOLDEN) & _MASK
        z = self.state
        z = ((z ^ (z >> 30)) * _MIX1) & _MASK
        z = ((z ^ (z >> 27)) * _MIX2) & _MASK
        return z ^ (z >> 31)

    def _below(self, n: int) -> int:
        return ((self._next() >> 32) * n) >> 32

    # ---- helpers -------------------------------------------------------------------------
    def _strength(self, x: np.ndarray) -> float:
        # Algorithm 3
        d = 1.0
        for b in self.boxes:
            if np.all(b[0] < x) and np.all(x < b[1]):
                d += 1.0
        return d

    def _valid(self, x: np.ndarray) -> bool:
        return bool(np.all(np.abs(x) <= self.p.coord_limit))

    def _deg(self, i: int) -> int:
        return int((self.age[i] >= 0).sum())

    def _nbrs(self, i: int) -> np.ndarray:
        return np.flatnonzero(self.age[i] >= 0)

    def _remove_edge(self, i: int, j: int) -> None:
        self.age[i, j] = self.age[j, i] = -1

    def _kill(self, i: int) -> None:
        self.age[i, :] = -1
        self.age[:, i] = -1
        self.alive[i] = False

    def _new(self, x: np.ndarray, e: float, u: float) -> int:
        r = int(np.flatnonzero(~self.alive)[0])
        self.pos[r] = x
        self.E[r] = e
        self.U[r] = u
        self.delta[r] = self._strength(x)
        self.alive[r] = True
        return r

    def _weight(self, i: int) -> float:
        p = self.p.strength_power
        return self.E[i] * self.delta[i] if p == 1.0 else self.E[i] * self.delta[i] ** p

    # ---- Algorithm 1: sampling -----------------------------------------------------------
    def _draw(self, pts: np.ndarray) -> list[np.ndarray]:
        p = self.p
        n = pts.shape[0]
        if n == 0:
            return []
        # reservoir: keep points still inside a box, add fresh box rows, drop the oldest
        self.res = [x for x in self.res if self._strength(x) > 1.0] if len(self.boxes) else []
        fresh: list[int] = []
        if len(self.boxes) > 0 and p.box_refresh > 0:
            for _probe in range(p.box_max_probes):
                rows = (self._below(n) + np.arange(min(p.box_window, n))) % n
                x = pts[rows].astype(np.float64)
                hit = (np.abs(x) <= p.coord_limit).all(axis=1)
                inside = np.zeros(len(rows), dtype=bool)
                for b in self.boxes:
                    inside |= ((b[0] < x) & (x < b[1])).all(axis=1)
                hit &= inside
                if not hit[: p.box_sniff].any():
                    continue
                take = min(max(1, p.box_refresh // 8), p.box_refresh - len(fresh))
                fresh.extend(rows[hit][:take].tolist())
                if len(fresh) == p.box_refresh:
                    break
        self.res = (self.res + [pts[j].astype(np.float64) for j in fresh])[-p.box_reservoir :]
        pool = self.res if len(self.res) >= p.box_min_points else []
        V = []
        for i in range(p.lam):
            if pool and i % p.attention_period == 0:
                V.append(pool[self._below(len(pool))].copy())
            else:
                for _tr in range(p.sample_tries):
                    x = pts[self._below(n)].astype(np.float64)
                    if self._valid(x):
                        V.append(x)
                        break
        return V

    # ---- Algorithm 2 ---------------------------------------------------------------------
    def update(self, points, attention_boxes=None) -> int:
        """One learning cycle; same arguments and return value as ``DDGNG.update``."""
        pts = _check_points(points)
        if attention_boxes is None or not self.attention:
            self.boxes = np.zeros((0, 2, 3))
        else:
            self.boxes = _check_boxes(attention_boxes)
        for i in np.flatnonzero(self.alive):
            self.delta[i] = self._strength(self.pos[i])
        V = self._draw(pts)
        if not V:
            return 0
        if not self.alive.any():
            self._new(V[0], 0.0, 0.0)
            self._new(V[min(1, len(V) - 1)], 0.0, 0.0)
        for v in V:
            self._step(v)
        self._insert()
        return len(V)

    def _step(self, v: np.ndarray) -> None:
        p = self.p
        self.t += 1
        idx = np.flatnonzero(self.alive)
        if len(idx) < 2:
            return
        diff = v - self.pos[idx]
        d = diff[:, 0] * diff[:, 0] + diff[:, 1] * diff[:, 1] + diff[:, 2] * diff[:, 2]
        order = np.lexsort((idx, d))
        s1, s2 = int(idx[order[0]]), int(idx[order[1]])
        d1, d2 = float(d[order[0]]), float(d[order[1]])
        # lines 5–7 (with the max-degree eviction of the kernels)
        if self.age[s1, s2] >= 0:
            self.age[s1, s2] = self.age[s2, s1] = 0
        else:
            for a in (s1, s2):
                if self._deg(a) >= p.max_degree:
                    nb = self._nbrs(a)
                    ages = self.age[a, nb]
                    j = int(nb[np.flatnonzero(ages == ages.max())[0]])
                    self._remove_edge(a, j)
                    if self._deg(j) == 0:
                        self._kill(j)
            self.age[s1, s2] = self.age[s2, s1] = 0
        # lines 8–10
        self.E[s1] += d1
        self.U[s1] += d2 - d1
        self.pos[s1] = self.pos[s1] + p.eta1 * (v - self.pos[s1])
        if len(self.boxes):
            self.delta[s1] = self._strength(self.pos[s1])
        # lines 11–15
        for j in self._nbrs(s1):
            self.pos[j] = self.pos[j] + p.eta2 * (v - self.pos[j])
            if len(self.boxes):
                self.delta[j] = self._strength(self.pos[j])
            a = self.age[s1, j] + 1
            if a > p.g_max:
                self._remove_edge(s1, j)
                if self._deg(j) == 0:
                    self._kill(j)
            else:
                self.age[s1, j] = self.age[j, s1] = a
        # lines 16–20
        idx = np.flatnonzero(self.alive)
        if self.t % p.kappa == 0 and len(idx) > 2:
            emax = self.E[idx].max()
            order = np.lexsort((idx, self.U[idx]))
            li = int(idx[order[0]])
            if emax > p.k * self.delta[li] * self.U[li]:
                nb = self._nbrs(li)
                c = sum(1 for j in nb if self._deg(j) == 1)
                if len(idx) - 1 - c >= 2:
                    self._kill(li)
                    for j in nb:
                        if self._deg(j) == 0:
                            self._kill(j)
        # lines 21–22
        self.E *= 1.0 - p.beta
        self.U *= 1.0 - p.chi

    def _insert(self) -> None:
        p = self.p
        idx = np.flatnonzero(self.alive)
        if len(idx) < 2 or len(idx) >= p.max_nodes:
            return
        w = np.array([self._weight(i) for i in idx])
        u = int(idx[np.flatnonzero(w == w.max())[0]])
        nb = self._nbrs(u)
        if len(nb) == 0:
            return
        wn = np.array([self._weight(j) for j in nb])
        f = int(nb[np.flatnonzero(wn == wn.max())[0]])
        x = 0.5 * (self.pos[u] + self.pos[f])
        self.E[u] *= 1.0 - p.alpha
        self.E[f] *= 1.0 - p.alpha
        r = self._new(x, 0.5 * (self.E[u] + self.E[f]), 0.5 * (self.U[u] + self.U[f]))
        self._remove_edge(u, f)
        self.age[u, r] = self.age[r, u] = 0
        self.age[f, r] = self.age[r, f] = 0

    # ---- read-out ------------------------------------------------------------------------
    @property
    def nodes(self) -> np.ndarray:
        """(n, 3) float64, metres, live nodes in slot order."""
        return self.pos[self.alive].copy()

    @property
    def edges(self) -> np.ndarray:
        """(m, 2) int64, i < j into ``nodes``, sorted."""
        idx = np.flatnonzero(self.alive)
        remap = np.full(len(self.alive), -1)
        remap[idx] = np.arange(len(idx))
        i, j = np.nonzero(np.triu(self.age >= 0, 1))
        e = np.stack([remap[i], remap[j]], axis=1).astype(np.int64)
        return e[np.lexsort((e[:, 1], e[:, 0]))] if len(e) else e.reshape(0, 2)

    @property
    def strength(self) -> np.ndarray:
        """(n,) float64 node strength δ."""
        return self.delta[self.alive].copy()

    @property
    def error(self) -> np.ndarray:
        """(n,) float64 accumulated error E."""
        return self.E[self.alive].copy()

    @property
    def utility(self) -> np.ndarray:
        """(n,) float64 utility U."""
        return self.U[self.alive].copy()
