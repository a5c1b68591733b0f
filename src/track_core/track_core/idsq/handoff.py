"""Handoff package of Table 1 step 5, ``(t + 1, p(x⁽ᵗ⁺¹⁾|z̄⁽ᵗ⁺¹⁾))``, its wire format and its validation.

Wire format (little-endian, our choice; the paper only says the sparse belief is handed off):

    header  '<4sBxHHIdddHHI'  = 46 bytes
            magic b'IDSQ', version 1, pad, sender u16, receiver u16, step u32,
            grid x0 f64, y0 f64, cell f64, nx u16, ny u16, n_cells u32
    body    n × u32 flat cell index, then n × f32 mass

so a handoff costs ``HEADER_BYTES + 8·n`` bytes (``payload_bytes``): the communication cost per
step we report. The sender is the receiver's *previous leader* (triplet rule).
- Version 2 (``prediction='drift'``): the header, ``'<ffH'`` = 10 bytes (v̂x, v̂y f32 [m/s],
  observation count u16), the body: ``HEADER_BYTES + MOTION_BYTES + 8·n``. No motion: version 1.
- Version 3 (``prediction='bank'``): n = stored (hypothesis, cell) entries, ``'<fH'`` = 6 bytes
  (lattice spacing f32 [m/s], J u16), then n × u32 key j·n_cells + cell and n × f32 mass:
  ``HEADER_BYTES + BANK_BYTES + 8·n``; the receiver rebuilds the lattice from the spacing and v_max.
- Revoke: ``'<4sBxHHI'`` = 14 bytes, magic b'IDSR', version 1, sender, receiver, step
  (``encode_revoke``, ``decode_revoke``).

On DDS the package is ``track_msgs/IdsqHandoff`` (revoke: ``IdsqRevoke``) field for field:
``Package``; ``to_package`` rounds as the bytes do and ``from_package`` reads back with every
structural check, so a belief is the same to the bit either way. ``validate_handoff`` returns
``None`` or a one-line reason (never raises); ``decode_handoff`` and ``from_package`` raise
``ValueError`` with one; ``peek_header`` still reads sender, receiver, step so a refusal can be
answered; ``read_package`` gives what ``HandoffLedger.on_handoff`` takes (``Handoff``, ``Unusable``
or ``Revocation``).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np

from track_core.idsq.grid import GridSpec, SparseBelief
from track_core.idsq.prediction import Bank, Motion, bank_from_joint

MAGIC = b'IDSQ'
VERSION = 1
VERSION_MOTION = 2
VERSION_BANK = 3
VERSIONS = (VERSION, VERSION_MOTION, VERSION_BANK)
_MOTION = struct.Struct('<ffH')
MOTION_BYTES = _MOTION.size
_BANK = struct.Struct('<fH')
BANK_BYTES = _BANK.size
_ADDRESS = struct.Struct('<4sBxHHI')  # the header up to the step: magic, version, sender, receiver, step
_HEADER = struct.Struct(_ADDRESS.format + 'dddHHI')
HEADER_BYTES = _HEADER.size
REVOKE_MAGIC = b'IDSR'
REVOKE_BYTES = _ADDRESS.size
MASS_TOL = 1e-3  # |Σ mass − 1| allowed (float32 body)


@dataclass(frozen=True)
class Handoff:
    """One handoff: step number, sender (= receiver's previous leader), receiver, sparse belief."""

    step: int
    sender: int
    receiver: int
    grid: GridSpec
    idx: np.ndarray
    mass: np.ndarray
    motion: Motion | Bank | None = None

    @classmethod
    def from_belief(cls, step: int, sender: int, receiver: int, belief: SparseBelief) -> Handoff:
        return cls(step, sender, receiver, belief.grid, belief.idx, belief.mass, belief.motion)

    def belief(self) -> SparseBelief:
        """The carried belief in float64, renormalised (call only after ``validate_handoff``)."""
        m = np.asarray(self.mass, dtype=float)
        return SparseBelief(self.grid, np.asarray(self.idx, dtype=np.int64), m / m.sum(), self.motion)


def payload_bytes(n_cells: int, motion: bool = False, bank: bool = False) -> int:
    """Bytes on the wire for ``n_cells`` stored cells (or joint entries with ``bank``): header [+ motion
    or bank] + 8 bytes per entry."""
    return HEADER_BYTES + (MOTION_BYTES if motion else 0) + (BANK_BYTES if bank else 0) + 8 * int(n_cells)


def _header_problem(h: Handoff, grid: GridSpec, n_sensors: int | None, receiver: int | None) -> str | None:
    if h.grid != grid:
        return f'wrong grid: got {h.grid}, expected {grid}'
    if not isinstance(h.step, (int, np.integer)) or h.step < 0:
        return f'step={h.step} must be an integer >= 0'
    if n_sensors is not None:
        bad = [f'{k}={v} outside [0, {n_sensors - 1}]' for k, v in (('sender', h.sender), ('receiver', h.receiver))
               if not 0 <= v < n_sensors]
        if bad:
            return bad[0]
    if receiver is not None and h.receiver != receiver:
        return f'addressed to sensor {h.receiver}, not {receiver}'
    return None


def _index_problem(idx: np.ndarray, mass: np.ndarray, grid: GridSpec) -> str | None:
    if idx.ndim != 1 or mass.shape != idx.shape:
        return f'index shape {idx.shape} and mass shape {mass.shape} must be equal 1-D'
    if idx.size == 0:
        return 'empty belief'
    if not np.issubdtype(idx.dtype, np.integer):
        return f'cell indices have dtype {idx.dtype}, expected integers'
    if idx.min() < 0 or idx.max() >= grid.n_cells:
        return f'cell index outside [0, {grid.n_cells - 1}]'
    if np.any(np.diff(idx) <= 0):
        return 'cell indices not strictly increasing (duplicate or unsorted)'
    return None


def _mass_problem(mass: np.ndarray) -> str | None:
    if not np.all(np.isfinite(mass)):
        return f'belief has {int(np.sum(~np.isfinite(mass)))} non-finite mass value(s)'
    if np.any(mass < 0):
        return f'belief has negative mass (min {float(mass.min()):.3g})'
    total = float(np.sum(mass, dtype=float))
    if abs(total - 1.0) > MASS_TOL:
        return f'belief mass sums to {total:.6g}, expected 1 ± {MASS_TOL}'
    return None


def validate_handoff(h: Handoff, grid: GridSpec, n_sensors: int | None = None,
                     receiver: int | None = None) -> str | None:
    """``None`` if ``h`` is usable by ``receiver`` on ``grid``, else a one-line reason."""
    idx, mass = np.asarray(h.idx), np.asarray(h.mass)
    return (_header_problem(h, grid, n_sensors, receiver) or _index_problem(idx, mass, grid)
            or _mass_problem(mass))


@dataclass(frozen=True, eq=False)
class Package:
    """The handoff's fields as they travel (module docstring): ``cells`` u32 flat cell indices, or joint
    keys j·n_cells + cell in version 3; ``mass`` f32; the motion (version 2: ``velocity`` [m/s],
    ``observations``) and lattice (version 3: ``bank_spacing`` [m/s], ``hypotheses``) fields, 0 otherwise."""

    version: int
    step: int
    sender: int
    receiver: int
    x0: float
    y0: float
    cell: float
    nx: int
    ny: int
    cells: np.ndarray
    mass: np.ndarray
    velocity: tuple[float, float] = (0.0, 0.0)
    observations: int = 0
    bank_spacing: float = 0.0
    hypotheses: int = 0


def _f32(x: float) -> float:
    return float(np.float32(x))


def to_package(h: Handoff) -> Package:
    """``h`` as it travels, rounded as the bytes round it (joint keys and masses for a ``Bank``)."""
    g = h.grid
    head = (h.step, h.sender, h.receiver, g.x0, g.y0, g.cell, g.nx, g.ny)
    if isinstance(h.motion, Bank):
        b = h.motion
        return Package(VERSION_BANK, *head, np.asarray(b.key, dtype='<u4'), np.asarray(b.mass, dtype='<f4'),
                       bank_spacing=_f32(b.step), hypotheses=int(b.n_hyp))
    cells, mass = np.asarray(h.idx, dtype='<u4'), np.asarray(h.mass, dtype='<f4')
    if h.motion is None:
        return Package(VERSION, *head, cells, mass)
    vx, vy = (_f32(v) for v in h.motion.velocity)
    return Package(VERSION_MOTION, *head, cells, mass, (vx, vy), int(h.motion.count))


def _foreign_fields(p: Package) -> str | None:
    """A motion or lattice field set in a package of another version."""
    if p.version != VERSION_MOTION and (any(v != 0 for v in p.velocity) or p.observations != 0):
        return f'velocity/observations are set in a version-{p.version} handoff (version {VERSION_MOTION} only)'
    if p.version != VERSION_BANK and (p.bank_spacing != 0 or p.hypotheses != 0):
        return f'bank_spacing/hypotheses are set in a version-{p.version} handoff (version {VERSION_BANK} only)'
    return None


def from_package(p: Package) -> Handoff:
    """The ``Handoff`` a package carries; ``ValueError`` with a one-line reason if it is unreadable
    (unknown version, arrays of different lengths, a field of another version, bad grid, motion or
    joint belief). The belief itself is checked by ``validate_handoff``."""
    if p.version not in VERSIONS:
        raise ValueError(f'unknown handoff version {p.version}, expected one of {", ".join(map(str, VERSIONS))}')
    cells, mass = np.asarray(p.cells), np.asarray(p.mass)
    if cells.ndim != 1 or cells.shape != mass.shape:
        raise ValueError(f'handoff has {cells.size} cells but {mass.size} masses')
    why = _foreign_fields(p)
    if why is not None:
        raise ValueError(why)
    try:
        grid = GridSpec(p.x0, p.y0, p.cell, p.nx, p.ny)
    except ValueError as exc:
        raise ValueError(f'bad grid in handoff: {exc}') from None
    idx, mass = cells.astype(np.int64), mass.astype(float)
    if p.version == VERSION_BANK:
        return _bank_handoff(p.step, p.sender, p.receiver, grid, p.bank_spacing, p.hypotheses, idx, mass)
    motion = None
    if p.version == VERSION_MOTION:
        try:
            motion = Motion(np.array(p.velocity, dtype=float), p.observations)
        except ValueError as exc:
            raise ValueError(f'bad motion in handoff: {exc}') from None
    return Handoff(p.step, p.sender, p.receiver, grid, idx, mass, motion)


def encode_handoff(h: Handoff, check: bool = True) -> bytes:
    """Pack ``h`` (see the module docstring); ``check`` refuses a package ``validate_handoff`` rejects."""
    if check:
        why = validate_handoff(h, h.grid)
        if why is not None:
            raise ValueError(f'refusing to encode handoff: {why}')
    p = to_package(h)
    head = _HEADER.pack(MAGIC, p.version, p.sender, p.receiver, p.step, p.x0, p.y0, p.cell, p.nx, p.ny, len(p.cells))
    if p.version == VERSION_MOTION:
        head += _MOTION.pack(*p.velocity, p.observations)
    elif p.version == VERSION_BANK:
        head += _BANK.pack(p.bank_spacing, p.hypotheses)
    return head + p.cells.tobytes() + p.mass.tobytes()


def decode_handoff(data: bytes) -> Handoff:
    """Unpack bytes from ``encode_handoff``; ``ValueError`` with a one-line reason if undecodable."""
    if len(data) < HEADER_BYTES:
        raise ValueError(f'handoff of {len(data)} bytes is shorter than the {HEADER_BYTES}-byte header')
    magic, ver, sender, receiver, step, x0, y0, cell, nx, ny, n = _HEADER.unpack_from(data)
    if magic != MAGIC or ver not in VERSIONS:
        raise ValueError(f'bad handoff magic/version {magic!r}/{ver}, expected {MAGIC!r}/{VERSIONS}')
    has_motion, has_bank = ver == VERSION_MOTION, ver == VERSION_BANK
    if len(data) != payload_bytes(n, has_motion, has_bank):
        raise ValueError(f'handoff length {len(data)} != {payload_bytes(n, has_motion, has_bank)} for {n} cells')
    extra, off = {}, HEADER_BYTES
    if has_motion:
        vx, vy, count = _MOTION.unpack_from(data, off)
        extra, off = {'velocity': (vx, vy), 'observations': count}, off + MOTION_BYTES
    elif has_bank:
        spacing, n_hyp = _BANK.unpack_from(data, off)
        extra, off = {'bank_spacing': spacing, 'hypotheses': n_hyp}, off + BANK_BYTES
    cells = np.frombuffer(data, offset=off, dtype='<u4', count=n)
    mass = np.frombuffer(data, offset=off + 4 * n, dtype='<f4', count=n)
    return from_package(Package(ver, step, sender, receiver, x0, y0, cell, nx, ny, cells, mass, **extra))


def _bank_handoff(step: int, sender: int, receiver: int, grid: GridSpec, bstep: float, n_hyp: int,
                  key: np.ndarray, mass: np.ndarray) -> Handoff:
    """Handoff of a joint (version 3) body: checked, then carried as its marginal plus the ``Bank``."""
    if not (np.isfinite(bstep) and bstep > 0 and n_hyp >= 1):
        why = f'bad bank lattice {bstep} m/s, J={n_hyp}'
    elif key.size == 0:
        why = 'empty belief'
    elif key.max() >= n_hyp * grid.n_cells or np.any(np.diff(key) <= 0):
        why = f'joint keys not strictly increasing in [0, {n_hyp * grid.n_cells - 1}]'
    else:
        why = _mass_problem(mass)
    if why is not None:
        raise ValueError(f'bad joint belief in handoff: {why}')
    b = bank_from_joint(grid, bstep, n_hyp, key, mass, 0.0)
    return Handoff(step, sender, receiver, grid, b.idx, b.mass, b.motion)


def receive_handoff(data: bytes, grid: GridSpec, n_sensors: int | None = None,
                    receiver: int | None = None) -> tuple[Handoff | None, str | None]:
    """Decode and validate: ``(handoff, None)`` if usable, else ``(None, one-line reason)``."""
    try:
        h = decode_handoff(data)
    except ValueError as exc:
        return None, str(exc)
    why = validate_handoff(h, grid, n_sensors, receiver)
    return (None, why) if why is not None else (h, None)


def peek_header(data: bytes) -> tuple[int, int, int] | None:
    """``(sender, receiver, step)`` from the first header fields, even when the rest is unusable (short,
    wrong grid, bad body), so that a refusal can still be answered; ``None`` without a readable
    magic/version."""
    if len(data) < _ADDRESS.size:
        return None
    magic, version, sender, receiver, step = _ADDRESS.unpack_from(data)
    return (sender, receiver, step) if magic == MAGIC and version in VERSIONS else None


@dataclass(frozen=True)
class Unusable:
    """A handoff that did not read as a package: why, and its (sender, receiver, step) when readable."""

    reason: str
    address: tuple[int, int, int] | None = None


@dataclass(frozen=True)
class Revocation:
    """``sender`` revokes its handoff of ``step`` to ``receiver`` (the chain rule of ``leader_protocol``)."""

    sender: int
    receiver: int
    step: int


def read_package(data: bytes) -> Handoff | Unusable | Revocation:
    """Bytes (a handoff or a revoke) as ``HandoffLedger.on_handoff`` takes them; never raises."""
    rev = decode_revoke(data)
    if rev is not None:
        return Revocation(*rev)
    try:
        return decode_handoff(data)
    except ValueError as exc:
        return Unusable(str(exc), peek_header(data))


def encode_revoke(step: int, sender: int, receiver: int) -> bytes:
    """The 14-byte revoke of ``sender``'s handoff of ``step`` to ``receiver`` (module docstring)."""
    return _ADDRESS.pack(REVOKE_MAGIC, 1, sender, receiver, step)


def decode_revoke(data: bytes) -> tuple[int, int, int] | None:
    """``(sender, receiver, step)`` of a revoke, ``None`` if ``data`` is not one."""
    if len(data) != REVOKE_BYTES:
        return None
    magic, version, sender, receiver, step = _ADDRESS.unpack_from(data)
    return (sender, receiver, step) if magic == REVOKE_MAGIC and version == 1 else None
