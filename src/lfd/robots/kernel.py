"""The forward-kinematics kernel of :class:`lfd.robots.Robot`: a sparse program per robot.

Every joint step ``T_i = T_{i-1} @ O'_i @ Rz(q_i)`` (internal z-axis joint frames, see
:mod:`lfd.robots.robot`) is written per column of the rotation, in a batch-last layout:
with ``u, v, w = R_{i-1} @ O'_i[:3, :3]`` (columns) and ``p_o = O'_i[:3, 3]``,

.. code-block:: text

    x_i = cos(q_i) u + sin(q_i) v,   y_i = cos(q_i) v - sin(q_i) u,   z_i = w,
    p_i = p_{i-1} + R_{i-1} p_o

No 4 x 4 matrix is formed. The products with the constant ``O'_i`` are compiled once into
lists of non-zero terms: the joint origins of URDF and DH arms are mostly signed
permutations with one translation, so ``u, v, w`` are usually columns of ``R_{i-1}`` with a
sign (no arithmetic: the sign is carried along and folded into ``cos``/``sin``), and a
joint step costs four multiply-adds and one add over ``(3, B)`` instead of a 4 x 4 product.
Entries within ``4 eps`` of 0 or +-1 (a DH twist of ``pi / 2`` gives ``cos = 6e-17``) are
snapped, which moves results by at most a few ``eps``.

CPU batches go through in blocks of :data:`BLOCK_ROWS` rows so that the working set stays in
the cache; without autograd the tool pose is written straight into the ``(B, 4, 4)`` output.
``benchmarks/kinematics_speed.py`` measures it against Pinocchio.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from torch import Tensor

__all__ = ["BLOCK_ROWS", "ChainProgram"]

#: Rows per block on the CPU (each ``(3, b)`` column 192 kB in float64); measured best of
#: 2048 / 4096 / 8192 / 16384 on the 2-core development machine.
BLOCK_ROWS = 8192

_SNAP = 4 * np.finfo(np.float64).eps

Terms = tuple[tuple[int, float], ...]  # (column index 0..2, coefficient) of a linear combination
_IDENTITY: tuple[Terms, Terms, Terms] = (((0, 1.0),), ((1, 1.0),), ((2, 1.0),))


def _terms(vector: np.ndarray) -> Terms:
    """Non-zero entries of a length-3 vector, with values near 0 or +-1 snapped to them."""
    out = []
    for k, a in enumerate(np.asarray(vector, dtype=np.float64)):
        if abs(a) <= _SNAP:
            continue
        if abs(abs(a) - 1.0) <= _SNAP:
            a = float(np.sign(a))
        out.append((k, float(a)))
    return tuple(out)


@dataclass(frozen=True)
class _Step:
    rotation: tuple[Terms, Terms, Terms]  # columns of the constant rotation
    translation: Terms


def _step(transform: np.ndarray) -> _Step:
    return _Step(tuple(_terms(transform[:3, j]) for j in range(3)), _terms(transform[:3, 3]))


# A column while the chain runs: (tensor (3, B) or (3, 1), coefficient) -- the value is
# tensor * coefficient, applied lazily (folded into the next product).
_Column = tuple[Tensor, float]


def _combine(cols: tuple[_Column, ...], terms: Terms) -> _Column | None:
    """``sum_k a_k cols[k]``; a single term stays lazy (a column and a coefficient, no arithmetic)."""
    if not terms:
        return None
    if len(terms) == 1:
        k, a = terms[0]
        return cols[k][0], cols[k][1] * a
    (k, a), *rest = terms
    out = cols[k][0] * (a * cols[k][1])
    for k, a in rest:
        out = out.add(cols[k][0], alpha=a * cols[k][1])
    return out, 1.0


def _value(column: _Column) -> Tensor:
    tensor, coefficient = column
    return tensor if coefficient == 1.0 else tensor * coefficient


def _moved(position: Tensor, column: _Column | None) -> Tensor:
    return position if column is None else position.add(column[0], alpha=column[1])


class ChainProgram:
    """The compiled joint steps of one chain; runs on any batch, dtype and device.

    Args:
        origins: ``(n, 4, 4)`` constant transforms ``O'_i`` (base folded into the first).
        tool: ``(4, 4)`` constant tool transform after the last joint.
    """

    def __init__(self, origins: np.ndarray, tool: np.ndarray) -> None:
        self.steps = tuple(_step(o) for o in np.asarray(origins, dtype=np.float64))
        self.tool = _step(np.asarray(tool, dtype=np.float64))
        self._start: dict[tuple[torch.dtype, torch.device], tuple[tuple[_Column, ...], Tensor]] = {}

    def run(self, q: Tensor, keep_frames: bool = False) -> tuple[list[Tensor], Tensor]:
        """Joint frames and tool frame, differentiable, column layout ``(4, 3, B)`` each.

        Args:
            q: ``(B, n)`` joint angles, rad (one block: no splitting here).
            keep_frames: also return the ``n`` joint frames (else an empty list).
        """
        frames: list[Tensor] = []
        cols, position = self._joints(q.T.contiguous(), frames if keep_frames else None)
        tool_cols, tool_position = self._tool(cols, position)
        batch = q.shape[0]
        tool = torch.stack([_value(c).expand(3, batch) for c in tool_cols] + [tool_position.expand(3, batch)])
        return frames, tool

    def tool_into(self, q: Tensor, out: Tensor) -> None:
        """Write the tool poses of ``q`` ``(B, n)`` into ``out`` ``(B, 4, 4)`` (contiguous; no autograd).

        ``q`` is transposed once (joints first); each block is assembled in a
        contiguous ``(4, 4, b)`` staging buffer and copied into ``out`` with one strided copy.
        """
        if q.device.type == "cpu":  # NumPy's transposing copy is ~2x torch's for a (B, 7) input
            angles = torch.from_numpy(np.ascontiguousarray(q.detach().numpy().T))
        else:
            angles = q.T.contiguous()
        block = BLOCK_ROWS if q.device.type == "cpu" else max(q.shape[0], 1)
        staging = None
        for start in range(0, q.shape[0], block):
            block_angles = angles[:, start : start + block]
            b = block_angles.shape[1]
            if staging is None or staging.shape[-1] != b:
                staging = q.new_zeros(4, 4, b)  # (rows, columns, b) of the homogeneous matrices
                staging[3, 3] = 1.0
            cols, position = self._tool(*self._joints(block_angles, None, staging[:3]), staging[:3, 3])
            for j, (tensor, coefficient) in enumerate(cols):
                if tensor.data_ptr() != staging[:3, j].data_ptr():  # not already written in place
                    torch.mul(tensor.expand(3, b), coefficient, out=staging[:3, j])
            if position.data_ptr() != staging[:3, 3].data_ptr():
                staging[:3, 3] = position
            out[start : start + b].permute(1, 2, 0).copy_(staging)

    def _joints(
        self, angles: Tensor, frames: list[Tensor] | None, target: Tensor | None = None
    ) -> tuple[tuple[_Column, ...], Tensor]:
        """Columns and position of the last joint frame for ``angles`` ``(n, B)`` (joints first).

        With ``target`` ``(3, 4, B)`` (no autograd) and a tool without rotation, the last joint
        writes its ``x``, ``y`` columns and, when the tool has no offset, the position there.
        """
        batch = angles.shape[1]
        cos, sin = torch.cos(angles).unbind(0), torch.sin(angles).unbind(0)
        scaled: dict[tuple[int, bool, float], Tensor] = {}

        def trig(i: int, use_sin: bool, coefficient: float) -> Tensor:
            """``coefficient * cos(q_i)`` (or sin), one small (B,) product when the coefficient is not 1."""
            base = (sin if use_sin else cos)[i]
            if coefficient == 1.0:
                return base
            key = (i, use_sin, coefficient)
            if key not in scaled:
                scaled[key] = base * coefficient
            return scaled[key]

        key = (angles.dtype, angles.device)
        if key not in self._start:  # the world frame: identity columns, zero position, (3, 1) each
            eye = torch.eye(3, dtype=angles.dtype, device=angles.device)
            self._start[key] = (tuple((eye[:, j : j + 1], 1.0) for j in range(3)), eye.new_zeros(3, 1))
        cols, position = self._start[key]
        for i, step in enumerate(self.steps):
            (tu, cu), (tv, cv), w = (_combine(cols, terms) for terms in step.rotation)
            last = target is not None and i == len(self.steps) - 1 and self.tool.rotation == _IDENTITY
            moved = _combine(cols, step.translation)
            if last and not self.tool.translation and moved is not None:
                position = torch.add(position, moved[0], alpha=moved[1], out=target[:, 3])
            else:
                position = _moved(position, moved)
            outs = (target[:, 0], target[:, 1]) if last else (None, None)
            x = torch.addcmul(tu * trig(i, False, cu), tv, trig(i, True, cv), out=outs[0])
            y = torch.addcmul(tv * trig(i, False, cv), tu, trig(i, True, cu), value=-1.0, out=outs[1])
            cols = ((x, 1.0), (y, 1.0), w)
            if frames is not None:
                frames.append(torch.stack((x, y, _value(w).expand(3, batch), position.expand(3, batch))))
        return cols, position

    def _tool(
        self, cols: tuple[_Column, ...], position: Tensor, target: Tensor | None = None
    ) -> tuple[tuple[_Column, ...], Tensor]:
        """Columns and position of the tool frame (the position written into ``target`` if given)."""
        tool_cols = tuple(_combine(cols, terms) for terms in self.tool.rotation)
        moved = _combine(cols, self.tool.translation)
        if target is not None and moved is not None:
            return tool_cols, torch.add(position, moved[0], alpha=moved[1], out=target)
        return tool_cols, _moved(position, moved)
