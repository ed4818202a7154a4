"""Writing results: atomic files and directories, JSON, PLY points and meshes.

Every output is one transaction: :func:`atomic_path` writes a file beside its target and
renames it into place, :func:`atomic_dir` builds a whole result directory beside its target
and swaps it in, with signals deferred at the swap and a lock against a second writer.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import tempfile
from pathlib import Path

import numpy as np

from interaction_tensor.errors import InputError


def output_path(path, what: str = "output file") -> Path:
    """``path`` as a Path; an empty one is refused in one line (``Path("")`` is the working
    directory, where a result would land unasked or be refused as a directory named '.')."""
    if path is None or (isinstance(path, str) and not path.strip()):
        raise InputError(None, f"the {what} path is empty; give one")
    return Path(path)


def make_dirs(directory, target=None) -> None:
    """``mkdir -p directory``; failures (a file in the way, no permission) become one-line
    errors naming ``target`` (default: the directory)."""
    directory = Path(directory)
    target = directory if target is None else target
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        raise InputError(target, "cannot write: a file is in the way of its directory "
                                 f"({directory})") from None
    except OSError as exc:
        raise InputError(target, f"cannot write: {exc.strerror}") from None


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    An interrupted or failed write leaves ``path`` as it was.
    """
    path = output_path(path)
    make_dirs(path.parent, path)
    if path.is_dir():
        raise InputError(path, "cannot write: it is a directory")
    with _signals_deferred():           # no temporary left by a signal between these lines
        try:
            fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part" + path.suffix,
                                       dir=path.parent)
        except OSError as exc:
            raise InputError(path, f"cannot write: {exc.strerror}") from None
        os.close(fd)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the file normal permissions
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        with _signals_deferred():
            if os.path.exists(tmp):
                os.unlink(tmp)


@contextlib.contextmanager
def atomic_dir(path, marker: str, allowed=None):
    """Yield a fresh temporary directory beside ``path``; swap it in for ``path`` on success.

    An interrupted or failed run leaves ``path`` as it was (the earlier complete result, or
    nothing). ``path`` may already exist only as an earlier output of the same command: empty,
    or holding ``marker`` (e.g. ``run.json``) and, when ``allowed`` (names) is given, nothing
    but those names; a directory holding other files is refused rather than replaced.

    A lock file beside ``path`` (``.NAME.lock``) makes a second run into the same directory
    refuse while the first is writing; temporaries left by a killed run are removed.
    """
    path = output_path(path, "output directory")
    _check_replaceable(path, marker, allowed)
    make_dirs(path.parent, path)
    with _directory_lock(path):
        _remove_stale(path)
        # SIGINT/SIGTERM wait while the temporary directory is made, swapped in or removed:
        # arriving in between they left it behind, or the old result moved aside. A signal
        # held while it is made is raised as that block ends, inside the try, so that the
        # finally below removes it
        tmp = None
        try:
            with _signals_deferred():
                try:
                    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".part",
                                                dir=path.parent))
                except OSError as exc:
                    raise InputError(path, f"cannot write: {exc.strerror}") from None
                os.chmod(tmp, 0o777 & ~_umask())
            yield tmp
            with _signals_deferred():
                _check_replaceable(path, marker, allowed)   # nothing new appeared meanwhile
                old = None
                if path.exists():
                    old = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".old",
                                                dir=path.parent))
                    os.replace(path, old / "previous")
                os.replace(tmp, path)
                if old is not None:
                    shutil.rmtree(old, ignore_errors=True)
        finally:
            with _signals_deferred():
                if tmp is not None and tmp.exists():
                    shutil.rmtree(tmp, ignore_errors=True)


@contextlib.contextmanager
def _signals_deferred():
    """Hold SIGINT and SIGTERM back (they are raised right after, with the handlers that were
    in place) while a few file operations that must not be cut in half run; a no-op off the
    main thread. Python-level handlers, not a signal mask: a mask holds only the calling
    thread, and the kernel hands a process signal to any thread that does not mask it (Numba's
    and tqdm's threads), whose arrival Python then runs in the main thread all the same."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught = []

    def hold(signum, _frame):
        caught.append(signum)

    previous = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        handler = signal.getsignal(sig)
        if handler is None:                 # installed outside Python: cannot be restored
            continue
        previous[sig] = signal.signal(sig, hold)
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        for sig in dict.fromkeys(caught):
            signal.raise_signal(sig)


def _check_replaceable(path: Path, marker: str, allowed) -> None:
    if not path.exists():
        return
    if not path.is_dir():
        raise InputError(path, "exists and is not a directory")
    names = {p.name for p in path.iterdir()}
    if names and marker not in names:
        raise InputError(path, f"exists and holds files that are not an earlier output "
                               f"(no {marker}); give a new or empty directory")
    if allowed is not None:
        foreign = sorted(names - set(allowed))
        if foreign:
            raise InputError(path, f"holds files that are not this command's output "
                                   f"({', '.join(foreign[:3])}{', ...' if len(foreign) > 3 else ''}"
                                   "); they would be lost, so give a new or empty directory")


@contextlib.contextmanager
def _directory_lock(path: Path):
    """An exclusive, non-blocking lock on ``.NAME.lock`` beside ``path`` (POSIX)."""
    try:
        import fcntl
    except ImportError:     # no advisory locks here: go on without one
        yield
        return
    lock_path = path.parent / f".{path.name}.lock"
    try:
        fh = open(lock_path, "a+")
    except OSError as exc:
        raise InputError(path, f"cannot write: {exc.strerror}") from None
    try:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise InputError(path, "another itensor run is writing this directory; wait for it "
                                   "or give another one") from None
        try:
            yield
        finally:
            try:
                lock_path.unlink()
            except OSError:
                pass
            fcntl.flock(fh, fcntl.LOCK_UN)
    finally:
        fh.close()


def _remove_stale(path: Path) -> None:
    """Remove ``.NAME.*.part`` / ``.NAME.*.old`` siblings left by a killed run (called with
    the directory's lock held, so no live run owns them)."""
    for pattern in (f".{path.name}.*.part", f".{path.name}.*.old"):
        for stale in path.parent.glob(pattern):
            if stale.is_dir():
                shutil.rmtree(stale, ignore_errors=True)


def _umask() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask


class Gathered:
    """``base[index]`` without gathering it: indexing (``g[i]``, ``g[a:b]``) gathers only the
    entries asked for, so a column of a million accepted pairs is searched a block at a
    time."""

    def __init__(self, base: np.ndarray, index: np.ndarray):
        self.base, self.index = base, index

    def __len__(self) -> int:
        return len(self.index)

    def __getitem__(self, i):
        return self.base[self.index[i]]


def write_json(path, obj) -> None:
    """Write ``obj`` as indented JSON, atomically.

    NumPy arrays in ``obj`` are written as one-line JSON lists, a block at a time (floats
    rounded to 6 decimals), so that a long array costs no million Python objects at once.
    """
    arrays = []

    def swap(o):
        if isinstance(o, np.ndarray):
            arrays.append(o.ravel())
            return f"@@itensor-array-{len(arrays) - 1}@@"
        if isinstance(o, dict):
            return {k: swap(v) for k, v in o.items()}
        if isinstance(o, (list, tuple)):
            return [swap(v) for v in o]
        return o

    parts = re.split(r'"@@itensor-array-(\d+)@@"', json.dumps(swap(obj), indent=1))
    with atomic_path(path) as tmp, open(tmp, "w") as fh:
        for i, part in enumerate(parts):
            if i % 2 == 0:
                fh.write(part)
                continue
            a = arrays[int(part)]
            fh.write("[")
            for s in range(0, len(a), 100_000):
                block = a[s:s + 100_000]
                block = np.round(block, 6) if block.dtype.kind == "f" else block
                fh.write(("," if s else "") + json.dumps(block.tolist())[1:-1])
            fh.write("]")
        fh.write("\n")


def write_ply_points(path, points, colors=None, normals=None, exact: bool = False,
                     **scalars) -> None:
    """Write a binary PLY point cloud, atomically.

    Parameters
    ----------
    points : (N, 3) float, metres; written as 32-bit floats, or with ``exact`` as 64-bit
        (the coordinates as they are)
    colors : (N, 3) uint8 or None
    normals : (N, 3) float or None
    scalars : name -> (N,) array, written as extra float32 vertex properties
    """
    points = np.asarray(points)
    coord = "<f8" if exact else "<f4"
    fields = [("x", coord), ("y", coord), ("z", coord)]
    if normals is not None:
        fields += [("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")]
    if colors is not None:
        fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    fields += [(k, "<f4") for k in scalars]
    kinds = {"<f4": "float", "<f8": "double", "u1": "uchar"}
    header = ["ply", "format binary_little_endian 1.0", "comment made by interaction-tensor",
              f"element vertex {len(points)}"]
    header += [f"property {kinds[t]} {n}" for n, t in fields]
    header.append("end_header")
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(("\n".join(header) + "\n").encode("ascii"))
            for s in range(0, len(points), 250_000):     # a block at a time: bounded memory
                sl = slice(s, s + 250_000)
                data = np.empty(len(points[sl]), dtype=fields)
                data["x"], data["y"], data["z"] = points[sl].T
                if normals is not None:
                    data["nx"], data["ny"], data["nz"] = np.asarray(normals[sl]).T
                if colors is not None:
                    data["red"], data["green"], data["blue"] = np.asarray(colors[sl],
                                                                          dtype=np.uint8).T
                for k, v in scalars.items():
                    data[k] = v[sl]
                fh.write(data.tobytes())


def write_mesh(path, vertices, faces=None, color=None) -> None:
    """Write a mesh (or, with no faces, a point cloud) as binary PLY, atomically: exactly
    the vertices given (64-bit coordinates) and the faces given, in their order, nothing
    merged, dropped or re-indexed; ``color`` (RGB or RGBA uint8) on every face (every point
    of a cloud)."""
    vertices = np.asarray(vertices, np.float64).reshape(-1, 3)
    if faces is None or len(faces) == 0:
        cols = None if color is None else np.tile(np.asarray(color, np.uint8)[:3], (len(vertices), 1))
        write_ply_points(path, vertices, colors=cols, exact=True)
        return
    faces = np.asarray(faces, np.int64).reshape(-1, 3)
    if faces.min() < 0 or faces.max() >= len(vertices) or len(vertices) >= 2 ** 31:
        raise ValueError("faces must index the vertices given (fewer than 2**31)")
    rgba = None if color is None else np.resize(np.asarray(color, np.uint8), 4)
    if rgba is not None and len(color) == 3:
        rgba[3] = 255
    face_fields = [("n", "u1"), ("v", "<i4", (3,))]
    if rgba is not None:
        face_fields += [(c, "u1") for c in ("red", "green", "blue", "alpha")]
    header = ["ply", "format binary_little_endian 1.0", "comment made by interaction-tensor",
              f"element vertex {len(vertices)}", "property double x", "property double y",
              "property double z", f"element face {len(faces)}",
              "property list uchar int vertex_indices"]
    if rgba is not None:
        header += [f"property uchar {c}" for c in ("red", "green", "blue", "alpha")]
    header.append("end_header")
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write(("\n".join(header) + "\n").encode("ascii"))
        fh.write(np.ascontiguousarray(vertices, "<f8").tobytes())
        for s in range(0, len(faces), 250_000):          # a block at a time: bounded memory
            block = faces[s:s + 250_000]
            data = np.empty(len(block), dtype=face_fields)
            data["n"] = 3
            data["v"] = block
            if rgba is not None:
                for c, value in zip(("red", "green", "blue", "alpha"), rgba):
                    data[c] = value
            fh.write(data.tobytes())
