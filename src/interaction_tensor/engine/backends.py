"""The scoring backends behind one interface.

A backend scores :class:`~interaction_tensor.engine.scoring.ScoreJob` s, (test point,
orientation) pairs against a keypoint table, and makes the same decisions as every other:

- ``numba``: the Numba kernels over the scene's grid (:mod:`.numba_backend`), candidates in
  Z-order so that a batch's keypoints stay in a compact region, with the neighbour cache where
  the test points are dense; the default when Numba imports;
- ``numpy``: the plain vectorised reference over SciPy's cKDTree (:func:`.scoring.score_pairs`);
- ``torch``: PyTorch on a CUDA device when one is present (:mod:`.torch_backend`).

:func:`open_backend` resolves a name (``auto`` included) and builds the backend's index once per
scene; detection calls :meth:`Backend.score` and never branches on names. Whatever scores, the
placement tests use the Numba grid where Numba imports (:attr:`Backend.grid`), the cKDTree
otherwise (the reference): exact either way.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np

from interaction_tensor.engine import numba_backend
from interaction_tensor.engine.numba_backend import CACHE_BYTES, score_jobs
from interaction_tensor.engine.scoring import (EXIT_AT_REJECTION, PairScores, ScoreJob, make_table,
                                               score_pairs)
from interaction_tensor.engine.torch_backend import (TorchIndex, import_torch, resolve_device,
                                                     score_pairs_torch)
from interaction_tensor.errors import SettingsError
from interaction_tensor.geometry.scene import Scene

#: Auto neighbour cache: used when at least this fraction of the scene's points is tested
#: (each block of space is then queried many times; below it building the cache costs more
#: than it saves).
CACHE_AUTO_FRACTION = 0.1
#: Auto neighbour cache on a machine where its kernels were never compiled: used only for a
#: search of at least this many pairs. Compiling them takes about half a minute on 2 cores,
#: once; kitchen5 at the defaults (1.47 M pairs) scores in 18.6 s through the cache instead of
#: 43.1 s, while the demo room (0.3 M pairs) would gain 2.4 s.
CACHE_COLD_PAIRS = 1_000_000
#: Memory of the auto neighbour cache, per scene point (bytes; at most
#: :data:`.numba_backend.CACHE_BYTES`): past it the oldest trees are dropped and rebuilt where
#: needed. 24 keeps a 2 M-point cloud at the defaults under 250 bytes a point.
CACHE_AUTO_BYTES_PER_POINT = 24
#: Least memory of the auto neighbour cache (bytes), whatever the scene's size: below it a
#: person's far keypoints make the cache drop and rebuild its trees hundreds of times.
CACHE_AUTO_FLOOR = 64 * 2**20


def resolve_backend(name: str) -> str:
    """``auto`` -> ``numba`` when Numba imports, else ``numpy``; a backend whose library is
    missing is refused with the install line."""
    if name == "auto":
        return "numba" if numba_backend.available() else "numpy"
    if name == "numba" and not numba_backend.available():
        raise SettingsError("backend 'numba' needs Numba: pip install numba")
    if name == "torch":

        import_torch()
    if name not in BACKENDS:
        raise SettingsError(f"unknown backend {name!r}; known: auto, {', '.join(BACKENDS)}")
    return name


def cache_pays(neighbour_cache: bool | None, test_fraction: float, pairs: int) -> bool:
    """Whether the Numba backend answers nearest neighbours from the neighbour cache:
    ``neighbour_cache`` when set, else (auto) when the test points are dense enough that each
    block of space is queried many times (at least :data:`CACHE_AUTO_FRACTION` of the scene's
    points tested) and the cache's kernels are compiled already or the search (``pairs``) is
    big enough to pay for compiling them (:data:`CACHE_COLD_PAIRS`). The results are the same
    either way."""
    if neighbour_cache is not None:
        return bool(neighbour_cache)
    return test_fraction >= CACHE_AUTO_FRACTION and (pairs >= CACHE_COLD_PAIRS
                                                     or cache_kernels_ready())


def cache_budget(n_points: int, neighbour_cache: bool | None) -> int:
    """Memory (bytes) the neighbour cache may take for a scene of ``n_points``: bounded by the
    scene's size when it is automatic, the most a cache holds when asked for."""
    if neighbour_cache is None:
        return min(CACHE_BYTES, max(CACHE_AUTO_FLOOR, CACHE_AUTO_BYTES_PER_POINT * n_points))
    return CACHE_BYTES


class Backend:
    """A scoring backend opened on one scene (:func:`open_backend`).

    Attributes
    ----------
    name : ``numba``, ``numpy`` or ``torch``
    scene : the scene it scores in
    grid : the Numba grid of the scene for the placement tests (the Numba backend's index;
        the torch backend's too where Numba imports), None for the cKDTree
    device : where the scores are computed (``cpu``, ``cuda:0``, ...)
    """

    name = ""

    def __init__(self, scene, device: str | None = None):
        self.scene = scene
        self.grid = None
        self.device = "cpu"

    def score(self, jobs: list, n_orientations: int, batch_size: int, bar=None,
              grouped: bool = True, cache: bool = False, cache_bytes: int = CACHE_BYTES,
              keep_cache: bool = False) -> list:
        """Score every job's pairs in batches of ``batch_size`` candidates; returns a
        :class:`~.scoring.PairScores` per job.

        A job's ``points`` are scene indices, gathered batch by batch to bound memory;
        ``grouped``: they come in runs of ``n_orientations`` pairs of one candidate each (else
        any pairs, ordered one by one). ``bar``: a tqdm bar advanced by candidates.
        ``cache``: answer nearest neighbours from the Numba backend's neighbour cache, of at
        most ``cache_bytes``, dropped after the scoring unless ``keep_cache`` (identical
        results; :func:`cache_pays`).
        """
        n_o = n_orientations
        step = batch_size * n_o
        totals = [np.zeros(len(j.points)) for j in jobs]
        acc = [np.zeros(len(j.points), bool) for j in jobs]
        at = [np.zeros(len(j.points), np.int32) for j in jobs]
        cmp_ = [0] * len(jobs)
        longest = max((len(j.points) for j in jobs), default=0)
        for start in range(0, longest, step):
            for i, j in enumerate(jobs):
                if start >= len(j.points):
                    continue
                sl = slice(start, start + step)
                res = self._score_slice(j, sl)
                totals[i][sl], acc[i][sl], at[i][sl] = res.score, res.accepted, res.decided_at
                cmp_[i] += res.comparisons
            if bar is not None:
                bar.update(min(step, longest - start) // n_o)
        return [PairScores(t, a, d, c) for t, a, d, c in zip(totals, acc, at, cmp_)]

    def _score_slice(self, job: ScoreJob, sl: slice) -> PairScores:
        raise NotImplementedError


class NumpyBackend(Backend):
    """The plain vectorised reference over SciPy's cKDTree."""

    name = "numpy"

    def __init__(self, scene, device=None):
        super().__init__(scene, device)
        _ = scene.tree

    def _score_slice(self, job, sl):
        s = self.scene
        return score_pairs(s.points[job.points[sl]], job.orient[sl], job.table, s,
                           job.threshold, vectors=job.vectors, early_exit=job.early_exit)


class TorchBackend(Backend):
    """PyTorch, on a CUDA device when one is present: the same decisions as the CPU."""

    name = "torch"

    def __init__(self, scene, device=None):

        super().__init__(scene, device)
        _ = scene.tree
        self.grid = scene.grid() if numba_backend.available() else None
        self.index = TorchIndex(scene, resolve_device(device))
        self.device = str(self.index.device)

    def _score_slice(self, job, sl):

        s = self.scene
        return score_pairs_torch(s.points[job.points[sl]], job.orient[sl], job.table,
                                 self.index, job.threshold, job.vectors, job.early_exit)


class NumbaBackend(Backend):
    """The Numba kernels over the scene's grid, with the neighbour cache where it pays."""

    name = "numba"

    def __init__(self, scene, device=None):
        super().__init__(scene, device)
        self.grid = scene.grid()

    def score(self, jobs, n_orientations, batch_size, bar=None, grouped=True, cache=False,
              cache_bytes=CACHE_BYTES, keep_cache=False):
        scene, grid = self.scene, self.grid
        n_o = n_orientations
        step = batch_size * n_o
        totals = [np.zeros(len(j.points)) for j in jobs]
        acc = [np.zeros(len(j.points), bool) for j in jobs]
        at = [np.zeros(len(j.points), np.int32) for j in jobs]
        cmp_ = [0] * len(jobs)
        longest = max((len(j.points) for j in jobs), default=0)
        # candidates in Z-order: a batch's keypoints stay in a compact region and consecutive
        # batches overlap (the neighbour cache is built once where they go)
        run = n_o if grouped else 1
        zorder = [spatial_order(scene.points, j.points, run, grid) for j in jobs]
        for start in range(0, longest, step):
            picks = [pairs_of(z[start // run:(start + step) // run], run) for z in zorder]
            batch = [ScoreJob(scene.points[j.points[pk]], j.orient[pk], j.table, j.threshold,
                              j.vectors, j.rho, j.early_exit,
                              None if j.resume_at is None else j.resume_score[pk],
                              None if j.resume_at is None else j.resume_at[pk])
                     for j, pk in zip(jobs, picks)]
            for i, (s, a, d, c) in enumerate(score_jobs(batch, grid, cache, cache_bytes)):
                totals[i][picks[i]], acc[i][picks[i]], at[i][picks[i]] = s, a, d
                cmp_[i] += int(c.sum())
            if bar is not None:
                bar.update(min(step, longest - start) // n_o)
        if cache and not keep_cache:
            grid.cache = None          # the cache's memory goes back after the scoring
        return [PairScores(t, a, d, c) for t, a, d, c in zip(totals, acc, at, cmp_)]


#: The backends by name (``DetectSettings.backend``).
BACKENDS = {"numba": NumbaBackend, "numpy": NumpyBackend, "torch": TorchBackend}


def open_backend(name: str, scene, device: str | None = None) -> Backend:
    """The backend ``name`` (``auto`` resolved) with its index built on ``scene``."""
    return BACKENDS[resolve_backend(name)](scene, device)


def spatial_order(points: np.ndarray, pair_points: np.ndarray, n_o: int, grid) -> np.ndarray:
    """Candidates (runs of ``n_o`` pairs of one scene point each, as detection makes them)
    in Z-order of their points over the grid's cells: (C,) int64 candidate numbers, stable
    (ties keep their order)."""
    cand = pair_points[::n_o]
    q = np.ascontiguousarray(points[cand], dtype=np.float64)
    return numba_backend.morton_order(q, np.asarray(grid.origin, np.float64), float(grid.cell))


def pairs_of(cands: np.ndarray, n_o: int) -> np.ndarray:
    """Pair indices of candidates ``cands`` (each candidate's ``n_o`` pairs, in order)."""
    return (cands[:, None] * n_o + np.arange(n_o)).ravel()


# --------------------------------------------------------------------------- first use
#: The process compiling the neighbour cache's kernels (:func:`prefetch_cache_kernels`).
_PREFETCH: subprocess.Popen | None = None
#: Set in that process, so that it does not start another.
PREFETCHING = "ITENSOR_PREFETCHING"


def cache_kernels_ready() -> bool:
    """Whether Numba's on-disk cache holds the neighbour cache's kernels (compiled by an
    earlier run on this machine)."""
    from interaction_tensor.engine import _numba_kernels as nk

    try:
        return all(os.path.exists(k._cache._cache_file._index_path)
                   for k in (nk.score_cached, nk.build_roots, nk.touched_roots))
    except AttributeError:          # another Numba's cache layout: assume compiled
        return True


def prefetch_cache_kernels() -> None:
    """On a machine where they were never compiled, compile the neighbour cache's kernels in a
    process of their own, in parallel with the work that comes before the scoring (the
    placement tests, which compile theirs): they take about half a minute on 2 cores, most of
    a first run. The scoring waits for it (:func:`await_cache_kernels`) and loads them from
    Numba's cache; the results are the same either way."""
    global _PREFETCH
    if _PREFETCH is not None or os.environ.get(PREFETCHING) or cache_kernels_ready():
        return
    env = dict(os.environ, **{PREFETCHING: "1"})
    try:
        _PREFETCH = subprocess.Popen(
            [sys.executable, "-c", "from interaction_tensor.engine.backends import "
                                   "compile_cache_kernels; compile_cache_kernels()"],
            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    except OSError:                 # no process can be started: compile when scoring
        _PREFETCH = None


def await_cache_kernels() -> None:
    """Wait for :func:`prefetch_cache_kernels`'s process, if one runs."""
    global _PREFETCH
    if _PREFETCH is not None:
        _PREFETCH.wait()
        _PREFETCH = None


def compile_cache_kernels() -> None:
    """Score a small synthetic scene through the neighbour cache, with the argument types
    detection uses (int32 point and int16 orientation indices, float64 positions), so that
    Numba compiles and caches the cache's kernels."""
    rng = np.random.default_rng(0)
    g = np.stack(np.meshgrid(np.arange(60), np.arange(60)), -1).reshape(-1, 2) * 0.01
    pts = np.column_stack([g, np.zeros(len(g))])
    scene = Scene(pts, np.tile([0.0, 0.0, 1.0], (len(pts), 1)), 0.01)
    n = 64
    table = make_table(rng.normal(scale=0.05, size=(n, 3)), rng.normal(scale=0.02, size=(n, 3)),
                       rng.random(n), 8, "paper", np.pi / 18, 5.0, 0.4)
    cand = np.arange(0, len(pts), 37, dtype=np.int32)
    job = ScoreJob(np.repeat(cand, 8), np.tile(np.arange(8, dtype=np.int16), len(cand)),
                   table, 0.5, "surface", scene.spacing, EXIT_AT_REJECTION)
    NumbaBackend(scene).score([job], 8, 64, grouped=True, cache=True)
