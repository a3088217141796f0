"""The band-by-band PNG writer, checked by decoding its files with OpenCV and Pillow."""

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from pencilbot.render.png import write_png_bands


@settings(max_examples=25, deadline=None)
@given(
    st.integers(1, 40),
    st.integers(1, 50),
    st.sampled_from([1, 3]),
    st.integers(1, 45),
    st.integers(0, 2**32 - 1),
)
def test_bands_of_any_height_decode_to_the_image(tmp_path_factory, rows, columns, channels, step, seed):
    rng = np.random.default_rng(seed)
    shape = (rows, columns) if channels == 1 else (rows, columns, 3)
    # Mostly paper with dark marks, plus noise: both runs and every byte value get through the filter.
    image = np.where(rng.random(shape) < 0.7, 255, rng.integers(0, 256, shape)).astype(np.uint8)
    path = tmp_path_factory.mktemp("png") / "image.png"
    write_png_bands(path, shape, (image[r : r + step] for r in range(0, rows, step)))
    with Image.open(path) as decoded:
        decoded.load()  # Pillow checks each chunk's CRC
        assert decoded.mode == ("L" if channels == 1 else "RGB")
        np.testing.assert_array_equal(np.asarray(decoded), image)
    np.testing.assert_array_equal(
        cv2.imread(str(path), cv2.IMREAD_UNCHANGED)[..., ::-1]
        if channels == 3
        else cv2.imread(str(path), cv2.IMREAD_UNCHANGED),
        image,
    )


def test_bands_that_do_not_make_the_image_leave_no_file(tmp_path):
    path = tmp_path / "short.png"
    with pytest.raises(ValueError, match="hold 2 rows, the image 3"):
        write_png_bands(path, (3, 4), [np.zeros((2, 4), np.uint8)])
    with pytest.raises(ValueError, match="more than"):
        write_png_bands(path, (3, 4), [np.zeros((2, 4), np.uint8)] * 2)
    with pytest.raises(ValueError, match="uint8 of shape"):
        write_png_bands(path, (3, 4), [np.zeros((3, 5), np.uint8)])
    assert list(tmp_path.iterdir()) == []
