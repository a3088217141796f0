"""Drawing styles: the artistic parameters of a plan, kept as data in ``configs/styles/*.toml``.

A style says how a photo becomes strokes (line length, edge threshold, hatch angles, pen width)
and where it goes on paper (page, orientation, margin). Shipped styles live in ``configs/styles/<name>.toml``
(found by :mod:`pencilbot.configs_io` in a wheel and in a source checkout), the user's own in the
``styles`` folder of their pencilbot folder (found first); a path to any TOML file works too. Every key is optional (missing keys
keep the defaults below); an unknown key or a wrongly typed value is a
:class:`~pencilbot.errors.ProfileError` naming the file and the key, so a typo never silently does
nothing. The rules are one table, :data:`STYLE_SCHEMA`, as for plotter profiles.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

from pencilbot import schema
from pencilbot.configs_io import config_names, read_config_table, user_setting
from pencilbot.errors import ProfileError
from pencilbot.imaging.strokes import GAMMA_RANGE, LONGEST_LENGTH, WIDTH_RANGE
from pencilbot.planning.hatching import HATCH_ANGLES, HATCH_COVERAGE, MIN_HATCH_RUN
from pencilbot.planning.layout import ORIENTATIONS
from pencilbot.planning.ordering import DEFAULT_ROUNDS
from pencilbot.planning.plan import DEFAULT_MARGIN
from pencilbot.planning.shading import BLANK_BELOW, FORM_SCALE, TONE_BLUR
from pencilbot.planning.vectorize import CLUTTER, EDGE_JOIN, MIN_EDGE_PIXELS
from pencilbot.units import DEFAULT_PEN_WIDTH

# Thinnest pen accepted, mm (fineliners go down to about this). Hatch spacing and the planning
# grid follow the pen width: a 0.01 mm pen on A4 would mean tens of thousands of hatch lines per
# layer and gigabytes of memory, for detail no plotter can draw.
MIN_PEN_WIDTH = 0.05
#: Upper bounds of style values (what a preview renders, what planning costs stays sane): the
#: widest pen (mm), the largest form the hatching follows and the widest tone blur (mm; a blur of
#: 1e6 mm asked OpenCV for terabytes), a size on the page (mm), rounds of order improvement.
MAX_PEN_WIDTH = 50.0
MAX_FORM_MM = 100.0
MAX_BLUR_MM = 20.0
MAX_SIZE_MM = 10_000.0
MAX_ORDER_ROUNDS = 1000
#: The plotting time a style may ask for (``time_budget``), as a multiple of the default budget:
#: up to four times (about two hours on an A4 sheet). Not less: a plan past its budgets makes
#: room by lightening its hatching, not its faces' runs, and at half the time a portrait of three
#: faces kept a twentieth of its hatching (face-api's sample1: whole-box rho 0.918 -> 0.147).
TIME_BUDGETS = (1.0, 4.0)
#: The style a plan uses when none is named.
DEFAULT_STYLE = "default"


@dataclass(frozen=True)
class Style:
    """How to draw a photo with a pen.

    Attributes
    ----------
    name : str
        The style's name (file stem), recorded in the plan's metadata.
    page : str
        Paper: ``"A5"``, ``"A4"``, ``"A3"``, ``"Letter"`` or ``"WxH"`` in mm.
    orientation : str
        ``"portrait"``, ``"landscape"`` or ``"auto"`` (follow the image's aspect).
    margin : float
        Blank border on every side, mm.
    pen_width : float
        Width of the line the pen draws, mm, at least ``MIN_PEN_WIDTH``. Sets hatch spacing and how close two parallel
        edge strokes may be before they merge.
    line_length : int or None
        Stroke length ℓ of the line drawing in image pixels (2 to ``LONGEST_LENGTH``); None picks
        it from the image size.
    stroke_gamma : float
        Tone curve γ of the line drawing (0.1 to 10): > 1 darkens its strokes, so fainter
        contours are drawn with the pen too; < 1 lightens them.
    stroke_width : float
        Width of the line drawing's strokes, image pixels (0.5 to 20): a wider raster stroke
        is drawn with more touching pen lines.
    texture : str or None
        A hand-drawn pencil texture image for the tone (the paper's H), a path; relative paths
        in a style file are relative to that file. None synthesises one.
    edge_threshold : float or None
        Edge strength (E in [0, 1]) below which no edge stroke is drawn; None: where the line
        drawing's stroke is 0.45 dark (which follows stroke_gamma).
    min_edge_pixels : int
        Fewest skeleton pixels a chain of contour strokes needs to be drawn; smaller ones are speckle.
    edge_join : float
        Consecutive strokes of a contour whose ends lie within this many ℓ are chained into one
        pen-down path through their crossing point (the pen retraces its own overshoot, it
        draws no chord), saving a pen lift each.
    edge_clutter : float
        Clutter (contours crossing a window of σ = 1.5 ℓ, times the incoherence of their
        directions; about 0.1 along contours, 2–3 in dense texture) above which a region is
        texture, not contour: there only long chains of strokes are drawn, and the hatching
        carries the texture's darkness. Larger keeps more detail (100 keeps every stroke).
    edge_lines : int
        Most touching pen lines a contour is drawn with where the raster's stroke is that many
        pen widths wide (1 to 3). 1, the default: a bold contour laid in two or three lines is
        darker than the photo there, and on the bench's 13 photos one line follows them better
        (``bench/fidelity.py``, before the budget: rho 0.909 → 0.936 on grace_hopper,
        0.935 → 0.955 on coffee).
    edge_budget : float
        Most contour length per area, mm per cm² of drawing (0: no limit). A picture that is
        texture through and through (a painting's brush strokes) would otherwise be drawn as
        an even scribble of edge strokes; past the budget the most cluttered contours go
        first. On the bench's painting (starry_night) plot time 50 → 25 min, pen-up 10.7 →
        7.1 m; it trims the busier photos too (grace_hopper's flag loses some of its stars).
    hatch : bool
        Whether tone is drawn as hatching at all (False: outline drawing only).
    hatch_angles : tuple of float
        Angle of each hatch family to the form, degrees (0: along the isophotes); the first
        family covers the lightest tones, later ones cross-hatch darker ones.
    hatch_coverage : float
        Fraction of paper (0, 1) one hatch family covers at its densest; spacing = pen_width /
        hatch_coverage.
    hatch_form : float
        Size (mm) of the forms the hatching follows (the structure tensor's scale); 0 hatches
        straight lines at ``hatch_angles`` to the page's 45°.
    hatch_blur : float
        The scale (Gaussian sigma, mm) at which the plot's tone is matched to the picture's.
    min_hatch_run : float
        Shortest hatch line kept, mm; shorter pieces would be dots.
    hatch_join : float
        Hatch runs whose ends lie closer than this (mm) are joined with a pen-down move,
        zig-zag fashion, saving a pen lift each (edges join only where they touch).
    hatch_blank_below : float
        Darkness in [0, 1) below which no hatching is drawn: the lightest tones stay paper
        rather than getting single lines centimetres apart.
    hatch_jitter : float
        Random offset of each hatch line as a fraction of its spacing (0 = ruled lines).
    faces : bool
        Whether faces are found (:mod:`pencilbot.imaging.faces`) and drawn with care: there
        the features are drawn from a finer edge threshold, light skin gets light tone instead
        of bare paper, and the hatching is finer and follows smaller forms. The plan's metadata
        lists the faces it treated so.
    face_lines : bool
        Whether a face's dark lines (eyes, brows, the mouth's line, nostrils) are also drawn as
        pen lines over its runs, as a portrait artist draws them
        (:func:`~pencilbot.planning.features.outside_faces`): the faces read as drawn faces at
        arm's length, at some cost in how closely their tone follows the photo's (docs/faces.md).
    order_rounds : int
        Rounds of local improvement the path ordering makes on nearest neighbour, per layer
        (each about one pass over the layer's paths); counted in rounds, not seconds, so a
        plan is reproducible. 0 keeps plain nearest-neighbour order.
    time_budget : float
        How long the plot may take, as a multiple of the default (1 to 4): 1 is about 28
        minutes for an A4 sheet on a servo pen plotter drawing at 50 mm/s, and a larger sheet
        gets more in proportion to its area. A one-pen plan keeps within it by drawing the faces
        with fewer, longer runs and the hatching lighter (:mod:`pencilbot.planning.plot_budget`);
        more time lets a portrait keep its faces' finest runs (docs/faces.md). A colour plan is
        held to no time.
    seed : int
        Seed of the pencil texture and the hatch jitter, so a plan is reproducible.
    """

    name: str = DEFAULT_STYLE
    page: str = "A4"
    orientation: str = "auto"
    margin: float = DEFAULT_MARGIN
    pen_width: float = DEFAULT_PEN_WIDTH
    line_length: int | None = None
    stroke_gamma: float = 1.0
    stroke_width: float = 1.0
    texture: str | None = None
    edge_threshold: float | None = None
    min_edge_pixels: int = MIN_EDGE_PIXELS
    edge_join: float = EDGE_JOIN
    edge_clutter: float = CLUTTER
    edge_lines: int = 1
    edge_budget: float = 5.0
    hatch: bool = True
    hatch_angles: tuple[float, ...] = HATCH_ANGLES
    hatch_coverage: float = HATCH_COVERAGE
    hatch_form: float = FORM_SCALE
    hatch_blur: float = TONE_BLUR
    min_hatch_run: float = MIN_HATCH_RUN
    hatch_join: float = 2.5
    hatch_blank_below: float = BLANK_BELOW
    hatch_jitter: float = 0.0
    faces: bool = True
    face_lines: bool = False
    order_rounds: int = DEFAULT_ROUNDS
    time_budget: float = 1.0
    seed: int = 0


def load_style(name_or_path: str | Path = DEFAULT_STYLE) -> Style:
    """Read a style by shipped name (e.g. ``"default"``) or from a TOML file path.

    Parameters
    ----------
    name_or_path : str or Path
        A name of a file in ``configs/styles`` without ``.toml``, or a path to a TOML file.

    Returns
    -------
    Style

    Raises
    ------
    ProfileError
        The style does not exist, is not valid TOML, has an unknown key or a bad value.
    """
    table, where, stem = read_config_table("styles", str(name_or_path), kind="style", file_kind="style file")
    style = with_overrides(Style(name=stem), table, where=f"style file {where}")
    source = Path(where)  # a user's file, by name (an absolute path) or by path; not a shipped style
    if style.texture is not None and (source.is_absolute() or Path(name_or_path).is_file()):
        style = dataclasses.replace(style, texture=str(source.parent / Path(style.texture).expanduser()))
    return style


def list_styles() -> list[str]:
    """Names of the styles there are: the user's and those shipped in ``configs/styles``."""
    return list(config_names("styles"))


def default_style() -> str:
    """The style a plan uses when none is named: the user's ``style`` setting, else
    :data:`DEFAULT_STYLE`."""
    return user_setting("style") or DEFAULT_STYLE


def with_overrides(style: Style, values: dict, *, where: str = "command line") -> Style:
    """``style`` with some parameters replaced, each checked as strictly as in a style file.

    Parameters
    ----------
    style : Style
    values : dict
        Parameter name → new value (TOML types: str, int, float, bool, list).
    where : str
        Where the values came from, for error messages.

    Raises
    ------
    ProfileError
        An unknown parameter or a bad value.
    """
    checked = {}
    for key, value in values.items():
        if key not in STYLE_SCHEMA:
            raise ProfileError(
                f"{where} has unknown key {key!r}; the known keys are: {', '.join(STYLE_SCHEMA)}"
            )
        checked[key] = STYLE_SCHEMA[key].apply(value, key, where)
    return dataclasses.replace(style, **checked)


# What each style key must be. The defaults are the Style fields'; a new key is a field there
# and a rule here (the check below keeps the two in step).
STYLE_SCHEMA: dict[str, schema.Rule] = {
    "page": schema.TEXT,
    "orientation": schema.choice(ORIENTATIONS),
    "margin": schema.number(0, MAX_SIZE_MM / 2, unit="mm"),
    "pen_width": schema.number(MIN_PEN_WIDTH, MAX_PEN_WIDTH, unit="mm"),
    "line_length": schema.whole(2, LONGEST_LENGTH, "pixels"),
    "stroke_gamma": schema.number(*GAMMA_RANGE),
    "stroke_width": schema.number(*WIDTH_RANGE, unit="pixels"),
    "texture": schema.Rule(
        "the path of a pencil texture image", lambda value: isinstance(value, str) and bool(value.strip())
    ),
    "edge_threshold": schema.number(0, 1, unit="(or leave it out for automatic)"),
    "min_edge_pixels": schema.whole(0, 1_000_000, unit="pixels"),
    "edge_join": schema.number(0, 100, unit="stroke lengths"),
    "edge_clutter": schema.number(0, 1000, above=True),
    "edge_lines": schema.whole(1, 3, "touching pen lines"),
    "edge_budget": schema.number(0, 1000, unit="mm per cm² (0: no limit)"),
    "hatch": schema.FLAG,
    "hatch_angles": schema.ANGLES,
    "hatch_coverage": schema.number(0, 1, above=True, below=True),
    "hatch_form": schema.number(0, MAX_FORM_MM, unit="mm"),
    "hatch_blur": schema.number(0, MAX_BLUR_MM, unit="mm"),
    "min_hatch_run": schema.number(0, MAX_SIZE_MM, unit="mm"),
    "hatch_join": schema.number(0, MAX_SIZE_MM, unit="mm"),
    "hatch_blank_below": schema.number(0, 1, below=True, unit="(darkness)"),
    "hatch_jitter": schema.number(0, 1, unit="(fraction of the hatch spacing)"),
    "faces": schema.FLAG,
    "face_lines": schema.FLAG,
    "order_rounds": schema.whole(0, MAX_ORDER_ROUNDS),
    "time_budget": schema.number(*TIME_BUDGETS, unit="times the default plotting time"),
    "seed": schema.whole(0, 2**32 - 1),
}
_FIELDS = [f.name for f in dataclasses.fields(Style) if f.name != "name"]
if list(STYLE_SCHEMA) != _FIELDS:  # pragma: no cover - a programming error, caught on import
    raise AssertionError(f"STYLE_SCHEMA keys {list(STYLE_SCHEMA)} must be the Style fields {_FIELDS}")
