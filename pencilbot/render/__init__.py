"""The rasteriser: pen paths in millimetres onto a sheet of paper, antialiased.

One rasteriser serves plan previews, fidelity measurements and the simulator, so all three agree
on what a drawn line looks like. The model of ink:

* a pen of width ``w`` mm covers the points within ``w/2`` of its path (round caps and joins);
* a pixel's coverage by one segment is the fraction of the pixel's area inside the segment's band:
  from the distance ``d`` between the pixel centre and the segment, the share of the pixel's
  projection onto the segment's normal (a trapezoid, a box when axis-aligned) that falls in
  ``[d − w/2, d + w/2]``. Exact for the straight part at any angle, so ink is conserved and
  diagonal lines are not lighter or darker than straight ones, even for pens thinner than a pixel;
* within one path a pixel is inked once (the maximum over the path's segments: a polyline's
  joints are not darker than its middle);
* separate paths (and separate calls) stack like translucent layers:
  ``darkness = 1 − Π(1 − coverage)``, accumulated as a sum of ``log(1 − coverage)``.

Everything is vectorised: candidate pixels are generated per segment, column by column along the
segment's major axis, only as many per column as the pen's band can reach, so long diagonal hatch
lines cost what they ink, not their bounding box. Coverage is computed in float32 in each
segment's own frame (offsets of a few pixels, so float32 keeps ~1e-7 accuracy) on cache-sized
dense blocks. "Once per path" is a group-max per (path, pixel), found with one ``np.maximum.at``
into a page-sized buffer (sorting only where separate paths overlap). Work is chunked to bound
memory; a path longer than a chunk keeps its per-pixel maximum open until it ends.

A sheet too large to hold (an A0 bed at 600 dpi is 0.56 gigapixels) is inked a band of rows at a
time (:class:`Bands`, :func:`render_band`) and streamed into a PNG (:func:`save_drawing_png`):
each band's pixels sit where the whole sheet puts them, so they get the same coverage.
"""

from pencilbot.render.canvas import (
    BAND_PIXELS,
    DEFAULT_DPI,
    TRAVEL_RGB,
    Bands,
    Canvas,
    band_rows,
    render_band,
    render_paths,
    sheet_pixels,
    travel_width,
)
from pencilbot.render.output import color_image, save_color_png, save_drawing_png, write_png

__all__ = [
    "BAND_PIXELS",
    "DEFAULT_DPI",
    "TRAVEL_RGB",
    "Bands",
    "Canvas",
    "band_rows",
    "color_image",
    "render_band",
    "render_paths",
    "save_color_png",
    "save_drawing_png",
    "sheet_pixels",
    "travel_width",
    "write_png",
]
