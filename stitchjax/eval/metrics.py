"""Evaluation metrics for motion in-betweening (float64 numpy).

Two families (docs/design.md §4 and §6):

* the official LAFAN1 benchmark metrics ``l2q``, ``l2p`` and ``npss``, reproduced exactly
  (same normalisation, same axes, same weighting as the reference implementation);
* the paper's metrics ``ade``, ``ade_best``, ``slde``, ``apd`` and ``foot_slide``;
* ground contact: the feet's penetration below the window's ground and the toes' clearance in swing
  (``ground_penetration_parts``, ``swing_clearance_parts``).

Shape conventions: ``B`` windows, ``T`` scored frames, ``J`` joints, ``S`` samples per window.
Positions are in the data's units (LAFAN1: centimetres); ``metres_per_unit`` converts them
(LAFAN1: 0.01, Human3.6M in millimetres: 0.001).

Every aggregated metric also has a ``*_per_window`` (or ``*_parts``) form returning per-window
numbers, so a caller can process windows in chunks and combine the results exactly.
"""
from __future__ import annotations

import numpy as np

from stitchjax.data import windows

LAFAN1_METRES_PER_UNIT = 0.01
FOOT_HEIGHT_THRESHOLD_CM = windows.FOOT_HEIGHT_THRESHOLD_CM
# A toe moving over the ground faster than this is in swing (60 cm/s = 2 cm/frame at 30 fps): a planted toe
# moves < 1 cm/frame. Chosen by hand, not tuned on any data split.
SWING_SPEED_CM_PER_S = 60.0
SWING_MIN_STEPS = 2  # a swing lasts at least 2 frame steps: a one-step jump (e.g. onto a keyframe) is not one


def _f64(x) -> np.ndarray:
    return np.asarray(x, dtype=np.float64)


# --------------------------------------------------------------------------- official LAFAN1


def l2q_per_window(prediction, ground_truth) -> np.ndarray:
    """Official L2Q per window.

    prediction, ground_truth: global quaternions (..., T, J, 4) (w, x, y, z), compared as they are
    (no sign alignment, as in the official benchmark).
    Returns (...): the L2 norm over the J*4 numbers of each frame, averaged over the T frames.
    """
    diff = _f64(prediction) - _f64(ground_truth)
    per_frame = np.sqrt(np.sum(diff**2, axis=(-2, -1)))
    return per_frame.mean(axis=-1)


def l2q(prediction, ground_truth) -> float:
    """Official LAFAN1 L2Q: mean over windows and frames of the per-frame L2 norm of the
    difference of all global quaternion components. Shapes (B, T, J, 4). Unitless."""
    return float(np.mean(l2q_per_window(prediction, ground_truth)))


def _normalise_positions(global_positions, mean, std) -> np.ndarray:
    x = _f64(global_positions)
    flat = x.reshape(x.shape[:-2] + (x.shape[-2] * x.shape[-1],))  # joint-major: j*3 + axis
    return (flat - _f64(mean).reshape(-1)) / _f64(std).reshape(-1)


def l2p_per_window(prediction, ground_truth, mean, std) -> np.ndarray:
    """Official L2P per window.

    prediction, ground_truth: global positions (..., T, J, 3) in data units.
    mean, std: (J*3,) training statistics of global positions (joint-major order, j*3 + axis).
    Returns (...): L2 norm over the J*3 z-scored numbers of each frame, averaged over frames.
    """
    diff = _normalise_positions(prediction, mean, std) - _normalise_positions(ground_truth, mean, std)
    return np.sqrt(np.sum(diff**2, axis=-1)).mean(axis=-1)


def l2p(prediction, ground_truth, mean, std) -> float:
    """Official LAFAN1 L2P: global positions z-scored with the training mean/std, L2 norm over the
    J*3 numbers per frame, mean over windows and frames. Shapes (B, T, J, 3); unitless."""
    return float(np.mean(l2p_per_window(prediction, ground_truth, mean, std)))


def _flatten_channels(x) -> np.ndarray:
    """(..., B, T, J, 4) or (..., B, T, D) -> (..., B, T, D); a 2-D input (T, D) stays as is."""
    x = _f64(x)
    return x.reshape(x.shape[:-2] + (-1,)) if x.ndim >= 4 else x


def npss_parts(prediction, ground_truth) -> tuple[np.ndarray, np.ndarray]:
    """Pieces of the official NPSS, per window, so chunks of windows can be combined exactly.

    prediction: (..., B, T, D) or (..., B, T, J, 4); ground_truth: (B, T, D) or (B, T, J, 4).
    Time is axis -2 of the flattened (..., B, T, D) arrays.
    Returns (weighted_emd (..., B), power (B,)): per window, the sum over channels of
    emd * ground-truth total power, and the sum over channels of ground-truth total power.
    NPSS = sum(weighted_emd) / sum(power) over all windows.
    """
    pred = _flatten_channels(prediction)
    gt = _flatten_channels(ground_truth)

    def normalised_cumulative_power(x):
        power = np.real(np.fft.fft(x, axis=-2)) ** 2
        total = power.sum(axis=-2)
        return np.cumsum(power / total[..., None, :], axis=-2), total

    cdf_gt, gt_total = normalised_cumulative_power(gt)
    cdf_pred, _ = normalised_cumulative_power(pred)
    emd = np.sum(np.abs(cdf_pred - cdf_gt), axis=-2)  # (..., B, D): L1 over frequency
    return np.sum(emd * gt_total, axis=-1), gt_total.sum(axis=-1)


def npss(prediction, ground_truth) -> float:
    """Official LAFAN1 NPSS (Gopalakrishnan et al. 2019, as in the LAFAN1 benchmark).

    prediction, ground_truth: (B, T, D) or (B, T, J, 4) (flattened to D = J*4 channels).
    Real part of the FFT over time, squared, normalised per (window, channel) by its total,
    cumulative sum, L1 distance between the two cumulative curves, averaged over all
    (window, channel) pairs weighted by the ground truth's total power. Unitless.
    """
    weighted, power = npss_parts(prediction, ground_truth)
    return float(np.sum(weighted) / np.sum(power))


# --------------------------------------------------------------------------- paper metrics


def displacement_per_window(samples, ground_truth) -> np.ndarray:
    """Mean Euclidean joint distance per window, in data units.

    samples: (..., B, T, J, 3) global positions; ground_truth: (B, T, J, 3).
    Returns (..., B): distance per joint averaged over joints and frames.
    """
    d = np.linalg.norm(_f64(samples) - _f64(ground_truth), axis=-1)
    return d.mean(axis=(-2, -1))


def ade(samples, ground_truth, metres_per_unit: float = LAFAN1_METRES_PER_UNIT) -> float:
    """Average displacement error in metres, averaged over samples, windows, frames and joints.

    samples: (S, B, T, J, 3) global positions of S samples (or (B, T, J, 3) for one);
    ground_truth: (B, T, J, 3). Data units times ``metres_per_unit`` gives metres.
    """
    return float(np.mean(displacement_per_window(samples, ground_truth)) * metres_per_unit)


def ade_best(samples, ground_truth, metres_per_unit: float = LAFAN1_METRES_PER_UNIT) -> float:
    """Best-of-S ADE in metres: per window the sample with the lowest ADE, averaged over windows.

    samples: (S, B, T, J, 3); ground_truth: (B, T, J, 3).
    """
    per = displacement_per_window(samples, ground_truth)
    per = per.reshape((-1, per.shape[-1]))
    return float(np.mean(per.min(axis=0)) * metres_per_unit)


def slde(samples, ground_truth, metres_per_unit: float = LAFAN1_METRES_PER_UNIT) -> float:
    """Second-last-frame displacement error in metres: ADE at the last *generated* frame
    (the frame before the target keyframe), averaged over samples, windows and joints.

    samples: (S, B, T, J, 3) with T the generated frames (or (B, T, J, 3)); ground_truth (B, T, J, 3).
    """
    s = _f64(samples)[..., -1:, :, :]
    g = _f64(ground_truth)[..., -1:, :, :]
    return ade(s, g, metres_per_unit)


def apd_per_window(samples) -> np.ndarray:
    """Average pairwise distance per window, in data units.

    samples: (S, B, T, J, 3) global positions. For each window, the mean over the S(S-1)/2 pairs
    of samples of the Euclidean distance between their flattened (T*J*3) sequences.
    Returns (B,); zeros when S == 1.
    """
    x = _f64(samples)
    num_samples, num_windows = x.shape[0], x.shape[1]
    if num_samples < 2:
        return np.zeros(num_windows)
    flat = x.reshape(num_samples, num_windows, -1)
    total = np.zeros(num_windows)
    for i in range(num_samples - 1):
        diff = flat[i + 1 :] - flat[i]  # (S-i-1, B, D)
        total += np.sqrt(np.sum(diff**2, axis=-1)).sum(axis=0)
    return total / (num_samples * (num_samples - 1) / 2)


def joint_spread_per_window(samples, frame: int | None = None) -> np.ndarray:
    """Mean pairwise per-joint distance between samples, per window, in data units.

    samples: (S, B, T, J, 3) global positions. For each window, the mean over the S(S-1)/2 pairs of
    samples, the frames (or the one ``frame`` given) and the joints of the Euclidean distance between the
    two samples' positions of that joint. Unlike APD it does not grow with the number of frames or joints.
    Returns (B,); zeros when S == 1.
    """
    x = _f64(samples)
    if frame is not None:
        x = x[:, :, frame:frame + 1]
    num_samples, num_windows = x.shape[0], x.shape[1]
    if num_samples < 2:
        return np.zeros(num_windows)
    total = np.zeros(num_windows)
    for i in range(num_samples - 1):
        distance = np.sqrt(np.sum((x[i + 1:] - x[i]) ** 2, axis=-1))  # (S-i-1, B, T, J)
        total += distance.mean(axis=(-2, -1)).sum(axis=0)
    return total / (num_samples * (num_samples - 1) / 2)


def apd(samples, metres_per_unit: float = LAFAN1_METRES_PER_UNIT) -> float:
    """Average pairwise distance in metres (diversity), averaged over windows.

    samples: (S, B, T, J, 3) global positions. 0 for S == 1 or identical samples.
    """
    return float(np.mean(apd_per_window(samples)) * metres_per_unit)


def ground_heights(global_positions, feet, up_axis: int = 1) -> np.ndarray:
    """Ground height per window: the lowest foot-joint height over all frames of the window.

    global_positions: (B, T, J, 3) ground-truth positions of the whole window; feet: joint indices.
    Returns (B,) in data units.
    """
    heights = _f64(global_positions)[..., :, list(feet), up_axis]
    return heights.min(axis=(-2, -1))


def foot_contact_weight(height_cm, height_threshold_cm: float = FOOT_HEIGHT_THRESHOLD_CM) -> np.ndarray:
    """The foot-slide metric's weight of a foot at ``height_cm`` above the ground: clip(2 - 2^(h/H), 0, 1),
    1 on the ground, 0 from H = ``height_threshold_cm`` up. Same shape as ``height_cm``."""
    return np.clip(2.0 - np.power(2.0, _f64(height_cm) / height_threshold_cm), 0.0, 1.0)


def foot_slide_parts(global_positions, ground, feet, metres_per_unit: float = LAFAN1_METRES_PER_UNIT,
                     height_threshold_cm: float = FOOT_HEIGHT_THRESHOLD_CM, up_axis: int = 1
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Pieces of the foot-slide metric, per window.

    global_positions: (..., B, T, J, 3) in data units; ground: (B,) ground heights (data units).
    For each foot joint and frame t < T-1: horizontal displacement from t to t+1 (cm) weighted by
    w = clip(2 - 2^(h/H), 0, 1), h = height at frame t above the ground, H = height_threshold_cm.
    Returns (weighted_sum_cm (..., B), count (..., B)) where count = number of (joint, frame)
    pairs with w > 0.
    """
    x = _f64(global_positions)[..., list(feet), :]  # (..., B, T, F, 3)
    cm_per_unit = metres_per_unit * 100.0
    horizontal = [a for a in range(3) if a != up_axis]
    step = x[..., 1:, :, :] - x[..., :-1, :, :]
    displacement_cm = np.linalg.norm(step[..., horizontal], axis=-1) * cm_per_unit  # (..., B, T-1, F)
    height_cm = (x[..., :-1, :, up_axis] - _f64(ground)[:, None, None]) * cm_per_unit
    weight = foot_contact_weight(height_cm, height_threshold_cm)
    return (weight * displacement_cm).sum(axis=(-2, -1)), (weight > 0).sum(axis=(-2, -1)).astype(np.float64)


def foot_slide(global_positions, ground, feet, metres_per_unit: float = LAFAN1_METRES_PER_UNIT,
               height_threshold_cm: float = FOOT_HEIGHT_THRESHOLD_CM, up_axis: int = 1) -> float:
    """Foot slide in cm/frame: the sum of weighted horizontal foot displacements divided by the
    number of (joint, frame) pairs with non-zero weight, pooled over all windows (and samples).

    global_positions: (..., B, T, J, 3) data units; ground: (B,) data units (see ``ground_heights``);
    feet: foot joint indices (LAFAN1: ankles and toes, (3, 4, 7, 8)). 0 when no foot is near the ground.
    """
    weighted, count = foot_slide_parts(global_positions, ground, feet, metres_per_unit, height_threshold_cm, up_axis)
    total = float(np.sum(count))
    return float(np.sum(weighted)) / total if total > 0 else 0.0


# ------------------------------------------------------------------------------------------ ground contact
# "The window's ground" is :func:`ground_heights`: the lowest height any ground-truth foot joint (ankles and
# toes) reaches anywhere in the window, i.e. the floor as the data's own feet touch it there (a planted toe
# joint sits a few cm above the modelled floor; a window on a raised floor has that floor). Foot slide uses
# the same ground. Heights below are measured along the up axis from it, in cm.


def ground_penetration_parts(global_positions, ground, feet, metres_per_unit: float = LAFAN1_METRES_PER_UNIT,
                             up_axis: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Pieces of the feet's penetration below the window's ground, per window.

    global_positions: (..., B, T, J, 3) data units; ground: (B,) the window's ground (:func:`ground_heights`,
    data units); feet: the foot joints (ankles and toes). Depth of a foot joint in a frame: how far (cm) it is
    below the ground, 0 when above. Returns (sum of depths (cm), joint-frames below, joint-frames, deepest
    depth (cm)), each (..., B). Pooled: mean depth of those below = sum / below; share below = below / all.
    The ground truth's depth is 0 by construction (its lowest foot joint is the ground).
    """
    x = _f64(global_positions)[..., list(feet), up_axis]  # (..., B, T, F)
    depth_cm = np.maximum(_f64(ground)[:, None, None] - x, 0.0) * (metres_per_unit * 100.0)
    below = depth_cm > 0.0
    total = np.full(depth_cm.shape[:-2], float(depth_cm.shape[-2] * depth_cm.shape[-1]))
    return (depth_cm.sum(axis=(-2, -1)), below.sum(axis=(-2, -1)).astype(np.float64), total,
            depth_cm.max(axis=(-2, -1), initial=0.0))


def swing_clearance_parts(global_positions, ground, toes, swing_speed_cm_per_frame: float,
                          metres_per_unit: float = LAFAN1_METRES_PER_UNIT, up_axis: int = 1,
                          min_steps: int = SWING_MIN_STEPS) -> tuple[np.ndarray, np.ndarray]:
    """Pieces of the toes' clearance in swing, per window: (sum over swings of each swing's highest toe
    height above the window's ground (cm), number of swings), each (..., B).

    global_positions: (..., B, T, J, 3) data units; ground: (B,) (:func:`ground_heights`); toes: toe joints.
    A swing of a toe is a run of at least ``min_steps`` consecutive frame steps in which it moves over the
    ground (horizontally) faster than ``swing_speed_cm_per_frame`` (:data:`SWING_SPEED_CM_PER_S` / fps); its
    clearance is the
    highest the toe gets above the ground over the frames of the run. A foot that slides instead of lifting
    makes swings with low clearance. Runs cut by the ends of the frames given count as swings.
    """
    x = _f64(global_positions)[..., list(toes), :]  # (..., B, T, F, 3)
    cm = metres_per_unit * 100.0
    horizontal = [a for a in range(3) if a != up_axis]
    step = np.linalg.norm(np.diff(x[..., horizontal], axis=-3), axis=-1) * cm  # (..., B, T-1, F)
    height = (x[..., up_axis] - _f64(ground)[:, None, None]) * cm  # (..., B, T, F)
    moving = step > float(swing_speed_cm_per_frame)
    total = np.zeros(moving.shape[:-2] + moving.shape[-1:])  # (..., B, F)
    count = np.zeros_like(total)
    peak = np.full_like(total, -np.inf)
    run = np.zeros_like(total)  # steps in the current run
    steps = moving.shape[-2]
    for t in range(steps):
        now = moving[..., t, :]
        peak = np.where(now, np.maximum(peak, np.maximum(height[..., t, :], height[..., t + 1, :])), peak)
        run = np.where(now, run + 1, 0)
        ends = now & (~moving[..., t + 1, :] if t + 1 < steps else True)
        counted = ends & (run >= min_steps)
        total += np.where(counted, peak, 0.0)
        count += counted
        peak = np.where(ends, -np.inf, peak)
    return total.sum(axis=-1), count.sum(axis=-1)


# ------------------------------------------------------------------------------------------ leg motion
# Artefacts a post-process on the legs can add (foot locking, :mod:`stitchjax.sample.footlock`): a knee that turns
# too fast, a joint that jumps, a foot held in the air where it should stand.
HOVER_HEIGHT_CM = 5.0  # a foot whose lowest joint is more than this above the ground is off it
HOVER_MIN_FRAMES = 10  # off it for this many frames in a row where the ground truth's foot is planted: hovering


def leg_joints(parents, feet) -> tuple:
    """((hip, knee, ankle, toe), ...) per leg from the foot joints ``feet`` (ankle, toe, ankle, toe, ...): the knee
    is the ankle's parent and the hip the knee's parent."""
    feet = tuple(int(f) for f in feet)
    return tuple((int(parents[parents[a]]), int(parents[a]), a, t) for a, t in zip(feet[0::2], feet[1::2]))


def knee_angles(global_positions, legs) -> np.ndarray:
    """(..., T, legs) each knee's inner angle in degrees (180: straight) of positions (..., T, J, 3); legs: as
    :func:`leg_joints` gives them."""
    x = _f64(global_positions)
    out = []
    for hip, knee, ankle, _ in legs:
        thigh, shin = x[..., hip, :] - x[..., knee, :], x[..., ankle, :] - x[..., knee, :]
        cos = np.sum(thigh * shin, axis=-1) / (np.linalg.norm(thigh, axis=-1) * np.linalg.norm(shin, axis=-1) + 1e-12)
        out.append(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
    return np.stack(out, axis=-1)


def knee_turn_max(global_positions, legs) -> np.ndarray:
    """(..., B) the largest change of a knee angle from one frame to the next (degrees per frame), per window, of
    positions (..., B, T, J, 3)."""
    return np.abs(np.diff(knee_angles(global_positions, legs), axis=-2)).max(axis=(-2, -1), initial=0.0)


def joint_jump_max(global_positions, metres_per_unit: float = LAFAN1_METRES_PER_UNIT) -> np.ndarray:
    """(..., B) the longest step of any joint from one frame to the next (cm), per window, of positions
    (..., B, T, J, 3) in data units."""
    step = np.linalg.norm(np.diff(_f64(global_positions), axis=-3), axis=-1) * (metres_per_unit * 100.0)
    return step.max(axis=(-2, -1), initial=0.0)


def _in_runs(mask, frames: int) -> np.ndarray:
    """(..., T) bool: the frames of ``mask`` (..., T) that lie in runs of at least ``frames`` along the last axis."""
    mask = np.asarray(mask, bool)
    ending = np.zeros(mask.shape, np.int64)  # the run's length up to and including each frame
    starting = np.zeros(mask.shape, np.int64)  # from each frame on
    length = mask.shape[-1]
    for t in range(length):
        ending[..., t] = np.where(mask[..., t], (ending[..., t - 1] if t else 0) + 1, 0)
        s = length - 1 - t
        starting[..., s] = np.where(mask[..., s], (starting[..., s + 1] if t else 0) + 1, 0)
    return mask & (ending + starting - 1 >= frames)


def hover_parts(global_positions, truth_positions, ground, legs, metres_per_unit: float = LAFAN1_METRES_PER_UNIT,
                up_axis: int = 1, min_frames: int = HOVER_MIN_FRAMES) -> tuple[np.ndarray, np.ndarray]:
    """Pieces of the share of leg-frames that hover, per window: (hovering leg-frames, leg-frames), each (..., B).

    global_positions: (..., B, T, J, 3) generated frames; truth_positions: (B, T, J, 3) the ground truth's same
    frames; ground: (B,) the window's ground (:func:`ground_heights`); legs: :func:`leg_joints`. A leg hovers in a
    frame when its foot's lowest joint (ankle or toe) is more than :data:`HOVER_HEIGHT_CM` above the ground while
    the ground truth's is planted (within :data:`FOOT_HEIGHT_THRESHOLD_CM`, where the foot-slide metric counts it
    on the ground), in a run of at least ``min_frames`` such frames.
    """
    cm = metres_per_unit * 100.0
    floor = _f64(ground)[:, None, None]

    def lowest(x):  # (..., B, T, legs) cm above the ground
        return (np.stack([_f64(x)[..., [a, t], up_axis].min(axis=-1) for _, _, a, t in legs], axis=-1) - floor) * cm

    hovering = (lowest(global_positions) > HOVER_HEIGHT_CM) & (lowest(truth_positions) <= FOOT_HEIGHT_THRESHOLD_CM)
    counted = _in_runs(np.moveaxis(hovering, -1, -2), min_frames)  # runs along the frames of each leg
    frames = np.full(counted.shape[:-2], float(counted.shape[-2] * counted.shape[-1]))
    return counted.sum(axis=(-2, -1)).astype(np.float64), frames
