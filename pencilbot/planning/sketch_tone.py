"""The darkness a one-pen plan's hatching is drawn to: the sketch's tone and a share of its lines.

The GMED sketch is R = L · T: the line drawing L over the pencil tone. The plan draws the tone
target J as hatching and the line drawing as contours, but the pen's contours are fewer than
the sketch's lines (a budget per area, a threshold), and where a line is not drawn the plot
followed the sketch's tone but not its lines. A share of the line drawing's darkness joins the
tone the hatching is drawn to, so a line the pen does not trace is still laid as tone along it.
"""

from __future__ import annotations

import numpy as np

#: Share of the line drawing's darkness (1 − L) in the hatching's darkness. Measured (face set,
#: bench/fidelity.py --faceset; plot vs own sketch r@1mm and whole-box rho): 2008_001322 0.892 ->
#: 0.912 and 0.950 -> 0.942, 2008_004176 0.894 -> 0.916 and 0.958 -> 0.947, dogs 0.920 -> 0.936
#: and 0.960 -> 0.957. All of it: r 0.96 but rho down to 0.85 (the sketch's lines in foliage and
#: hair are not the photo's tone); half: r 0.94, rho 0.92. 0.3 (was 0.2) once the hatch lines
#: were spread evenly (:mod:`pencilbot.planning.spread`: the plot follows its target closely
#: enough to afford it): r min 0.914 -> 0.924 (every photo of the set from 0.92), whole box min
#: 0.946 -> 0.945; on 13 other photos and 19 unseen or stress ones r up by up to 0.02, rho down
#: by at most 0.007 (bus.jpg 0.961 / 0.897 -> 0.954 / 0.914).
SKETCH_LINES = 0.3


def sketch_darkness(drawing) -> np.ndarray:
    """1 − J · (1 − SKETCH_LINES · (1 − L)) of a sketch with its tone (``drawing.tone``)."""
    lines = 1.0 - np.asarray(drawing.line.drawing, np.float32)
    return 1.0 - np.asarray(drawing.tone, np.float32) * (1.0 - np.float32(SKETCH_LINES) * lines)
