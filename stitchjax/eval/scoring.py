"""The running sums of the paper's protocol (:func:`stitchjax.eval.evaluate.evaluate_protocol`): the ground truth
every method is scored against, and per-method sums over chunks of windows, turned into the metrics at the end.

All float64 numpy; positions in the data's units (LAFAN1: cm), the metrics' units as ``evaluate`` lists them.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from stitchjax.eval import metrics
from stitchjax.skeleton import forward_kinematics

__all__ = ["Truth", "ground_truth", "MethodSums", "ContactSums"]


@dataclasses.dataclass(frozen=True)
class Truth:
    """What every length and method of one protocol run is scored against."""

    parents: tuple
    rotations: np.ndarray  # (N, T, J, 4) global rotations of the windows
    positions: np.ndarray  # (N, T, J, 3) global positions
    ground: np.ndarray  # each window's ground height (lowest ground-truth foot height)
    mean: np.ndarray  # (J*3,) training statistics, for L2P
    std: np.ndarray
    slide_kw: dict  # feet, metres_per_unit, up_axis of metrics.foot_slide_parts
    contact_kw: dict  # feet, toes, legs, metres_per_unit, up_axis, swing_speed_cm_per_frame of ContactSums


def ground_truth(windows, stats, feet, metres_per_unit: float, up_axis: int) -> Truth:
    """The :class:`Truth` of test windows (N, T, J, ...) and training ``stats`` (``mean``, ``std`` (J*3,))."""
    rotations_all = np.asarray(windows.rotations, dtype=np.float64)
    positions_all = np.asarray(windows.positions, dtype=np.float64)
    parents = tuple(int(p) for p in windows.skeleton.parents)
    mean, std = np.asarray(stats.mean, dtype=np.float64), np.asarray(stats.std, dtype=np.float64)
    gt_rot_all, gt_pos_all = forward_kinematics(rotations_all, positions_all, parents)
    ground_all = metrics.ground_heights(gt_pos_all, feet, up_axis)
    slide_kw = dict(feet=feet, metres_per_unit=metres_per_unit, up_axis=up_axis)
    fps = float(getattr(windows, "fps", 0.0) or 30.0)
    contact_kw = dict(slide_kw, toes=tuple(feet)[1::2], swing_speed_cm_per_frame=metrics.SWING_SPEED_CM_PER_S / fps,
                      legs=metrics.leg_joints(parents, feet))
    return Truth(parents, gt_rot_all, gt_pos_all, ground_all, mean, std, slide_kw, contact_kw)


class MethodSums:
    """Per-method running sums so windows can be processed in chunks."""

    def __init__(self):
        self.sums = dict.fromkeys(
            ("ade", "ade_best", "slde", "apd", "spread", "spread_mid", "npss", "l2p", "l2q", "slide",
             "slide_count"), 0.0
        )
        self.contact = ContactSums()
        self.count = 0  # sample-windows
        self.windows = 0

    def result(self, npss_power: float, metres_per_unit: float) -> dict:
        s, n, w = self.sums, max(self.count, 1), max(self.windows, 1)
        samples = n / w
        return {
            "apd": s["apd"] / w * metres_per_unit,
            "spread": s["spread"] / w * metres_per_unit * 100.0,
            "spread_mid": s["spread_mid"] / w * metres_per_unit * 100.0,
            "ade": s["ade"] / n * metres_per_unit,
            "ade_best": s["ade_best"] / w * metres_per_unit,
            "slde": s["slde"] / n * metres_per_unit,
            "npss": s["npss"] / (samples * npss_power),
            "foot_slide": s["slide"] / s["slide_count"] if s["slide_count"] > 0 else 0.0,
            "l2p": s["l2p"] / n,
            "l2q": s["l2q"] / n,
            **self.contact.result(),
        }

    def add(self, q, p, gt_q, gt_p, target_pose, ground, truth: Truth, start_pose=None) -> None:
        """Add one chunk of a method's FK predictions q, p (S, b, L, J, ...) against the ground truth
        gt_q, gt_p (b, L, J, ...); target_pose (1, b, 1, J, 3) ends the foot-slide track, start_pose
        (1, b, 1, J, 3) begins the toes' swings with it."""
        s, length = self.sums, p.shape[2]
        displacement = metrics.displacement_per_window(p, gt_p)  # (S, b)
        s["ade"] += float(displacement.sum())
        s["ade_best"] += float(displacement.min(axis=0).sum())
        s["slde"] += float(metrics.displacement_per_window(p[:, :, -1:], gt_p[:, -1:]).sum())
        s["apd"] += float(metrics.apd_per_window(p).sum())
        s["spread"] += float(metrics.joint_spread_per_window(p).sum())
        s["spread_mid"] += float(metrics.joint_spread_per_window(p, frame=length // 2).sum())
        s["npss"] += float(metrics.npss_parts(q, gt_q)[0].sum())
        s["l2p"] += float(metrics.l2p_per_window(p, gt_p, truth.mean, truth.std).sum())
        s["l2q"] += float(metrics.l2q_per_window(q, gt_q).sum())
        full = np.concatenate([p, np.broadcast_to(target_pose, p[:, :, :1].shape)], axis=2)
        weighted, count = metrics.foot_slide_parts(full, ground, **truth.slide_kw)
        s["slide"] += float(weighted.sum())
        s["slide_count"] += float(count.sum())
        framed = full if start_pose is None else np.concatenate(
            [np.broadcast_to(start_pose, p[:, :, :1].shape), full], axis=2)
        self.contact.add(p, framed, ground, truth.contact_kw, gt_p)
        self.count += displacement.size
        self.windows += displacement.shape[1]


class ContactSums:
    """Running sums of the ground-contact and leg-motion figures of one method or the truth:
    ``metrics.ground_penetration_parts`` and ``metrics.hover_parts`` on the generated frames,
    ``metrics.swing_clearance_parts``, ``knee_turn_max`` and ``joint_jump_max`` on them with both keyframes."""

    def __init__(self):
        self.depth = self.below = self.total = self.deepest = self.clearance = self.swings = 0.0
        self.hovering = self.leg_frames = self.knee_turn = self.jump = 0.0

    def add(self, generated, framed, ground, kw: dict, truth_generated=None) -> None:
        """generated: (..., b, L, J, 3) the generated frames; framed: the same between both keyframes; ground:
        (b,); truth_generated: (b, L, J, 3) the ground truth's generated frames (default: ``generated``)."""
        depth, below, total, deepest = metrics.ground_penetration_parts(
            generated, ground, kw["feet"], kw["metres_per_unit"], kw["up_axis"])
        clearance, swings = metrics.swing_clearance_parts(
            framed, ground, kw["toes"], kw["swing_speed_cm_per_frame"], kw["metres_per_unit"], kw["up_axis"])
        hovering, leg_frames = metrics.hover_parts(generated, generated if truth_generated is None else truth_generated,
                                                   ground, kw["legs"], kw["metres_per_unit"], kw["up_axis"])
        self.depth += float(depth.sum())
        self.below += float(below.sum())
        self.total += float(total.sum())
        self.deepest = max(self.deepest, float(np.max(deepest, initial=0.0)))
        self.clearance += float(clearance.sum())
        self.swings += float(swings.sum())
        self.hovering += float(hovering.sum())
        self.leg_frames += float(leg_frames.sum())
        self.knee_turn = max(self.knee_turn, float(np.max(metrics.knee_turn_max(framed, kw["legs"]), initial=0.0)))
        self.jump = max(self.jump, float(np.max(metrics.joint_jump_max(framed, kw["metres_per_unit"]), initial=0.0)))

    def result(self) -> dict:
        """{penetration, penetration_max, penetration_share, toe_clearance, hover_share, knee_turn_max,
        joint_jump_max}; toe_clearance None without swings."""
        return {"penetration": self.depth / self.below if self.below else 0.0,
                "penetration_max": self.deepest,
                "penetration_share": self.below / self.total if self.total else 0.0,
                "toe_clearance": self.clearance / self.swings if self.swings else None,
                "hover_share": self.hovering / self.leg_frames if self.leg_frames else 0.0,
                "knee_turn_max": self.knee_turn,
                "joint_jump_max": self.jump}
