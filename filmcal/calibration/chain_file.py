"""The chain file: emcee's HDF5 layout, written a chunk of steps at a time, with the run's configuration.

Apart from `filmcal.calibration.sampling` so that reading a calibration's
results (`filmcal.calibration.posterior`) does not import emcee: only running
or reading a chain does.
"""
from __future__ import annotations

import errno
import json
import shutil
from pathlib import Path

import emcee
import h5py
import numpy as np

__all__ = ["CHAIN_GROUP", "CHAIN_FORMAT", "ChunkedHDFBackend", "open_backend", "read_metadata", "read_stored"]

#: Group of the HDF5 file holding emcee's chain.
CHAIN_GROUP = "mcmc"
#: ``format`` of a chain's configuration (the HDF5 attribute `METADATA_ATTR`).
CHAIN_FORMAT = "filmcal-calibration-chain"
METADATA_ATTR = "filmcal_calibration"


class ChunkedHDFBackend(emcee.backends.HDFBackend):
    """emcee's HDF5 backend, writing the steps of a chunk at once when `flush` is called.

    The parent class opens the file for every step (milliseconds each); this
    one keeps the steps of a chunk in memory and appends them in one write.
    The file layout is emcee's own, so `emcee.backends.HDFBackend` reads it.
    Blobs are not supported (the calibration returns none).
    """

    def __init__(self, filename: str, name: str = CHAIN_GROUP) -> None:
        super().__init__(filename, name=name)
        self._pending: list = []

    def save_step(self, state, accepted) -> None:
        if state.blobs is not None:
            raise ValueError("blobs are not supported by this backend")
        self._pending.append((np.array(state.coords), np.array(state.log_prob), np.array(accepted),
                              state.random_state))

    def flush(self) -> None:
        """Append the pending steps, the acceptance counts and the last random state to the file."""
        if not self._pending:
            return
        coords, log_prob, accepted, random_states = zip(*self._pending)
        # HDF5 meets a full disk inside its own buffers and reports it from object finalisers, as tracebacks
        # that nothing can catch: a write that cannot fit is refused here first, as an error naming the file
        needed = 2 * sum(np.asarray(c).nbytes + np.asarray(p).nbytes for c, p in zip(coords, log_prob)) + 2**16
        free = shutil.disk_usage(Path(self.filename).resolve().parent).free
        if free < needed:
            raise OSError(errno.ENOSPC, "No space left on device", self.filename)
        with self.open("a") as f:
            g = f[self.name]
            it = int(g.attrs["iteration"])
            k = len(coords)
            g["chain"][it:it + k] = np.stack(coords)
            g["log_prob"][it:it + k] = np.stack(log_prob)
            g["accepted"][:] += np.sum(accepted, axis=0)
            for i, v in enumerate(random_states[-1]):
                g.attrs[f"random_state_{i}"] = v
            g.attrs["iteration"] = it + k
        self._pending.clear()


def open_backend(path: str | Path | None, metadata: dict, reset: bool, ndim: int
                  ) -> emcee.backends.Backend:
    """An emcee backend: in memory, or an HDF5 file (new, reset, or checked and continued)."""
    if path is None:
        return emcee.backends.Backend()
    path = Path(path)
    if path.exists() and not h5py.is_hdf5(path):
        raise ValueError(f"backend_path {str(path)!r} exists and is not an HDF5 file")
    backend = ChunkedHDFBackend(str(path))
    fresh = reset or not backend.initialized or backend.iteration == 0
    if not fresh:
        stored = read_metadata(path)
        if stored != json.loads(json.dumps(metadata)):
            raise ValueError(f"backend_path {str(path)!r} holds a chain of another configuration "
                             "(film, data, priors, options, walkers or seed); pass reset=True to start afresh")
        return backend
    backend.reset(metadata["n_walkers"], ndim)
    with h5py.File(path, "a") as f:
        f.attrs[METADATA_ATTR] = json.dumps(metadata)
    return backend


def read_metadata(path: Path) -> dict | None:
    """The configuration a chain file was written with (None: a file without one)."""
    with h5py.File(path, "r") as f:
        text = f.attrs.get(METADATA_ATTR)
    return None if text is None else json.loads(text)


def read_stored(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Chain and log probabilities of a chain file, read-only."""
    backend = emcee.backends.HDFBackend(str(path), name=CHAIN_GROUP, read_only=True)
    return backend.get_chain(), backend.get_log_prob()
