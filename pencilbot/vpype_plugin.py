"""``vpype pencilbot PHOTO``: pencilbot's drawing of a photo as layers of a vpype pipeline.

Registered as a vpype plugin through the ``vpype.plugins`` entry point (``pip install
"pencilbot[vpype]"``), so a photo goes into any pipeline::

    vpype pencilbot photo.jpg linesimplify gwrite --profile my_plotter out.gcode
    vpype pencilbot --no-hatch --pen-width 0.3 photo.jpg write out.svg

(vpype's commands take their options before their arguments.)
The plan is made exactly as ``pencilbot plan`` makes it (the same options, in pencilbot's units:
mm), and each of its layers — the hatch layers, lightest first, then ``edges`` — becomes a new
vpype layer after the pipeline's own, with its name (``vp_name``), pen width (``vp_pen_width``)
and colour (``vp_color``). With ``--pens`` (a colour plan) each *pen* becomes one vpype layer,
named by the pen, in load order, with its ink as colour: vpype's convention of a layer per pen,
so ``gwrite`` and plotting tools change pens between layers. vpype works in CSS pixels with Y down: the page's Y flip is applied
here. A dot (a one-point path) becomes a zero-length line, which vpype keeps and draws as a dot.
The page size is set unless the pipeline has set one.

This module is a front end, as the commands are: it may use everything below them.
"""

from __future__ import annotations

import argparse

import click
import numpy as np
import vpype
import vpype_cli

from pencilbot.commands.common import photo_style, plan_photo
from pencilbot.errors import PencilbotError
from pencilbot.imaging.io import DEFAULT_MAX_PIXELS
from pencilbot.machine.pens import list_pen_sets, load_pens
from pencilbot.planning.layout import ORIENTATIONS
from pencilbot.planning.plan import Plan
from pencilbot.planning.style import default_style, list_styles, with_overrides
from pencilbot.units import MM_PER_INCH

PX_PER_MM = 96.0 / MM_PER_INCH  # vpype's unit is the CSS pixel


@click.command("pencilbot")
@click.argument("photo", type=vpype_cli.PathType(exists=True, dir_okay=False))
@click.option("--style", metavar="NAME|FILE.toml", help=f"drawing style: {', '.join(list_styles())} or a .toml file "
              f"(default: {default_style()})")
@click.option("--page", metavar="A4|WxH", help="paper: A5, A4, A3, Letter or WxH in mm (default: the style's)")
@click.option("--orientation", type=click.Choice(ORIENTATIONS), help="auto turns the sheet to suit the photo")
@click.option("--margin", type=float, metavar="MM", help="blank border in mm (default: the style's)")
@click.option("--pen-width", type=float, metavar="MM", help="pen line width in mm (default: the style's)")
@click.option("--pens", metavar="NAME|FILE.toml", help=f"draw in colour with a pen set: {', '.join(list_pen_sets())} "
              "or a .toml file (one layer per pen)")
@click.option("--hatch/--no-hatch", default=None, help="draw the tone as hatching (default: as the style says)")
@click.option("--faces/--no-faces", default=None, help="draw faces with finer features and hatching (default: as the "
              "style says)")
@click.option("--max-pixels", type=int, default=DEFAULT_MAX_PIXELS, show_default=True, help="refuse larger images")
@click.option("--downscale", is_flag=True, help="shrink a too-large image instead")
@vpype_cli.global_processor
def pencilbot(document: vpype.Document, photo, style, page, orientation, margin, pen_width, pens, hatch, faces,
              max_pixels, downscale) -> vpype.Document:
    """Add pencilbot's pen drawing of PHOTO: its hatch layers and its edges, as new layers.

    The options are `pencilbot plan`'s, in mm; each layer gets its name, pen width and colour.
    """
    sheet = argparse.Namespace(style=style, page=page, orientation=orientation, margin=margin, pen_width=pen_width,
                               faces=faces)
    try:
        chosen = photo_style(sheet)
        if hatch is not None:
            chosen = with_overrides(chosen, {"hatch": hatch}, where="--hatch")
        plan = plan_photo(photo, chosen, max_pixels=max_pixels, downscale=downscale,
                          pens=None if pens is None else load_pens(pens))
    except PencilbotError as err:
        raise click.ClickException(str(err)) from None
    return add_plan(document, plan)


def add_plan(document: vpype.Document, plan: Plan) -> vpype.Document:
    """``document`` with every layer of ``plan`` added after its own layers (see the module).

    Parameters
    ----------
    document : vpype.Document
    plan : Plan
        Page mm, Y up.

    Returns
    -------
    vpype.Document
        The same document, its page size set from the plan's page unless it had one.
    """
    height = plan.page.height
    lid = max(document.layers, default=0)
    groups = ([(pen, layers) for pen, layers in plan.pen_runs()] if len(plan.pens) > 1
              else [(layer.name, (layer,)) for layer in plan.layers])
    for name, layers in groups:
        lines = [path if len(path) > 1 else np.vstack([path, path]) for layer in layers for path in layer.paths]
        lines = [(p[:, 0] + 1j * (height - p[:, 1])) * PX_PER_MM for p in lines]
        lid += 1
        document.add(vpype.LineCollection(lines), lid)
        added = document.layers[lid]
        added.set_property(vpype.METADATA_FIELD_NAME, name)
        added.set_property(vpype.METADATA_FIELD_PEN_WIDTH, layers[0].pen_width * PX_PER_MM)
        added.set_property(vpype.METADATA_FIELD_COLOR, vpype.Color(layers[0].color))
    if document.page_size is None:
        document.page_size = (plan.page.width * PX_PER_MM, height * PX_PER_MM)
    return document


pencilbot.help_group = "Plugins"
