# SPDX-License-Identifier: GPL-3.0-or-later
"""A Monte Carlo checkpoint is checked for internal consistency, not just format: a real
checkpoint of `rbc mc` whose `sweep` attribute is edited with h5py and whose content checksum is
recomputed, and the file resealed (so neither the checksum nor the seal can tell), is refused by
`rbc mc --resume`, because the sweep count disagrees with the stored time series.

The checksum is recomputed here from its definition (core/h5file.hpp, H5File::content_checksum:
FNV-1a 64 over every dataset's path (datasets in groups too, depth first in name order),
shape, datatype encoding and bytes, then every root attribute's name, datatype encoding and
bytes except the checksum's own, each in name order);
the test first checks that definition against the checksum rbc wrote."""
import os
import shutil
import struct
import subprocess

import numpy as np
import pytest

from conftest import rbc_executable

h5py = pytest.importorskip("h5py")

CHECKSUM = "content_checksum"
MASK = (1 << 64) - 1


class Fnv1a:
    def __init__(self):
        self.h = 0xcbf29ce484222325

    def add(self, data: bytes):
        h = self.h
        for b in data:
            h = ((h ^ b) * 0x100000001b3) & MASK
        self.h = h

    def add_string(self, s: bytes):
        self.add(struct.pack("<Q", len(s)))
        self.add(s)


def stored_bytes(obj_id, shape, dtype):
    """HDF5's encoding of the datatype, then the values as stored (no conversion)."""
    values = np.empty(shape, dtype=dtype)
    if isinstance(obj_id, h5py.h5d.DatasetID):
        obj_id.read(h5py.h5s.ALL, h5py.h5s.ALL, values, mtype=obj_id.get_type())
    else:
        obj_id.read(values, mtype=obj_id.get_type())
    return obj_id.get_type().encode() + values.tobytes()


def content_checksum(path):
    items_sets, items_attrs = [], []
    with h5py.File(path, "r") as f:
        names = []
        f.visititems(lambda name, obj: names.append(name)
                     if isinstance(obj, h5py.Dataset) else None)
        for name in names:
            d = f[name]
            record = struct.pack(f"<{len(d.shape)}Q", *d.shape)
            record += stored_bytes(d.id, d.shape, d.dtype)
            items_sets.append(("/" + name, record))
        for name in sorted(f.attrs.keys()):
            if name == CHECKSUM:
                continue
            a = f.attrs.get_id(name)
            items_attrs.append((name, stored_bytes(a, a.shape, a.dtype)))
    h = Fnv1a()
    for items in (items_sets, items_attrs):
        h.add(struct.pack("<Q", len(items)))
        for name, data in items:
            h.add_string(name.encode())
            h.add_string(data)
    return format(h.h, "x")


def stored_checksum(path):
    with h5py.File(path, "r") as f:
        a = f.attrs.get_id(CHECKSUM)
        raw = np.empty(a.shape, dtype=a.dtype)
        a.read(raw)
        return raw.tobytes().rstrip(b"\0").decode()


def reseal(path):
    """Writes the seal of the file's bytes again (core/h5file.hpp: the first 512 bytes, an HDF5
    user block, hold "rbc sealed HDF5 file\\n" and "fnv1a64 HEX16 bytes N\\n", the FNV-1a 64 and
    length of the bytes after the block, zero padded)."""
    data = bytearray(open(path, "rb").read())
    first = b"rbc sealed HDF5 file\n"
    assert data[:len(first)] == first
    h = Fnv1a()
    h.add(bytes(data[512:]))
    line = f"fnv1a64 {h.h:016x} bytes {len(data) - 512}\n".encode()
    data[len(first):512] = line + b"\0" * (512 - len(first) - len(line))
    open(path, "wb").write(bytes(data))


def set_checksum(path):
    """Recomputes the content checksum and the seal, as an rbc that wrote these values would."""
    value = content_checksum(path).encode()
    with h5py.File(path, "r+") as f:
        del f.attrs[CHECKSUM]
        f.attrs.create(CHECKSUM, np.bytes_(value), dtype=f"S{len(value) + 1}")
    reseal(path)


def rbc(*args, cwd):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    return subprocess.run([rbc_executable(), *args], capture_output=True, text=True, cwd=cwd,
                          env=env, timeout=300)


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory):
    d = tmp_path_factory.mktemp("mc_checkpoint")
    # One chain: the edits below change its sweep count (every chain's is in /chain_sweeps).
    out = rbc("mc", "--vertices", "100", "--sweeps", "12", "--sample-every", "2", "--chains", "1",
              "--checkpoint", "c.h5", "-q", cwd=d)
    assert out.returncode == 0, out.stderr
    return d / "c.h5"


def resume(path, cwd):
    return rbc("mc", "--vertices", "100", "--sweeps", "16", "--sample-every", "2", "--resume",
               str(path), "-q", cwd=cwd)


def test_the_checksum_definition_is_rbcs(checkpoint):
    assert content_checksum(checkpoint) == stored_checksum(checkpoint)


def test_an_edit_without_a_new_seal_is_refused_before_hdf5_reads_it(checkpoint, tmp_path):
    edited = tmp_path / "unsealed_edit.h5"
    shutil.copy(checkpoint, edited)
    with h5py.File(edited, "r+") as f:
        f.attrs.modify("sweep", np.int64(10))
    out = resume(edited, tmp_path)
    assert out.returncode == 2, (out.returncode, out.stdout, out.stderr)
    assert "is corrupt: its bytes do not match the checksum sealed with them" in out.stderr
    resealed = tmp_path / "resealed.h5"
    shutil.copy(checkpoint, resealed)
    reseal(resealed)  # the seal of unchanged bytes is the one rbc wrote
    assert open(resealed, "rb").read() == open(checkpoint, "rb").read()


def test_an_edited_sweep_count_with_a_recomputed_checksum_is_refused(checkpoint, tmp_path):
    with h5py.File(checkpoint, "r") as f:
        assert int(f.attrs["sweep"]) == 12 and int(f.attrs["series_rows"]) == 6
    edited = tmp_path / "edited.h5"
    shutil.copy(checkpoint, edited)
    with h5py.File(edited, "r+") as f:
        f.attrs.modify("sweep", np.int64(10**15))
        f["chain_sweeps"][0, 0] = 10**15
    set_checksum(edited)
    assert stored_checksum(edited) == content_checksum(edited)  # the checksum alone passes
    out = resume(edited, tmp_path)
    assert out.returncode == 2, (out.returncode, out.stdout, out.stderr)
    assert "is corrupt" in out.stderr and "sweep count 1000000000000000 disagrees with the " \
        "stored time series" in out.stderr, out.stderr
    assert out.stderr.count("\n") == 1, out.stderr  # one line
    assert out.stdout == ""

    # A sweep edited by one sample interval: also inconsistent with the 6 stored samples.
    with h5py.File(edited, "r+") as f:
        f.attrs.modify("sweep", np.int64(14))
        f["chain_sweeps"][0, 0] = 14
    set_checksum(edited)
    out = resume(edited, tmp_path)
    assert out.returncode == 2 and "disagrees" in out.stderr, out.stderr


def test_the_unedited_checkpoint_resumes_and_an_unchecksummed_edit_is_refused(checkpoint,
                                                                             tmp_path):
    copy = tmp_path / "copy.h5"
    shutil.copy(checkpoint, copy)
    out = resume(copy, tmp_path)
    assert out.returncode == 0, out.stderr
    with h5py.File(copy, "r") as f:
        assert int(f.attrs["sweep"]) == 12  # --resume without --checkpoint leaves it as it was
    with h5py.File(copy, "r+") as f:
        f.attrs.modify("sweep", np.int64(10**15))
    out = resume(copy, tmp_path)
    assert out.returncode == 2 and "checksum" in out.stderr, out.stderr
