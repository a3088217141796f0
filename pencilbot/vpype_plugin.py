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

This module is a front end, as the commands are: it plans through the application layer
(:mod:`pencilbot.app`), as they do, and imports none of theirs.
"""

from __future__ import annotations

import argparse

import click
import numpy as np
import vpype
import vpype_cli

from pencilbot.app.photo import plan_photo
from pencilbot.app.photo_options import add_photo_options, photo_request
from pencilbot.errors import PencilbotError
from pencilbot.planning.plan import Plan
from pencilbot.units import CSS_PX_PER_INCH, MM_PER_INCH

PX_PER_MM = CSS_PX_PER_INCH / MM_PER_INCH  # vpype's unit is the CSS pixel


def _photo_options(command):
    """``command`` with `pencilbot plan`'s photo options as click options: the same flags, help,
    defaults and checks (each value goes through the argparse option's own ``type``), declared
    once in :func:`pencilbot.app.photo_options.add_photo_options`."""
    parser = argparse.ArgumentParser(add_help=False)
    add_photo_options(parser)
    for action in reversed([a for a in parser._actions if a.option_strings and a.dest != "help"]):
        if action.nargs == 0 and not isinstance(action, argparse.BooleanOptionalAction):
            if action.const is not True:  # the listings (--list-styles, ...) belong to pencilbot's own CLI
                continue
            command = click.option(action.option_strings[0], action.dest, is_flag=True, help=action.help)(
                command
            )
            continue
        if isinstance(action, argparse.BooleanOptionalAction):
            flag = action.option_strings[0]
            command = click.option(f"{flag}/--no-{flag[2:]}", action.dest, default=None, help=action.help)(
                command
            )
            continue
        command = click.option(
            action.option_strings[0],
            action.dest,
            metavar=action.metavar,
            help=action.help,
            type=click.Choice(action.choices) if action.choices else None,
            default=action.default,
            show_default=action.default is not None,
            callback=_checked(action),
        )(command)
    return command


def _checked(action: argparse.Action):
    def convert(ctx, param, value):
        if value is None or action.type is None or not isinstance(value, str):
            return value
        try:
            return action.type(value)  # type: ignore[operator]  # our options' types are functions, never names
        except PencilbotError as err:
            raise click.BadParameter(str(err)) from None

    return convert


@click.command("pencilbot")
@click.argument("photo", type=vpype_cli.PathType(exists=True, dir_okay=False))
@_photo_options
@vpype_cli.global_processor
def pencilbot(document: vpype.Document, photo, **options) -> vpype.Document:
    """Add pencilbot's pen drawing of PHOTO: its hatch layers and its edges, as new layers.

    The options are `pencilbot plan`'s, in mm; each layer gets its name, pen width and colour.
    """
    args = argparse.Namespace(**options)
    try:
        plan = plan_photo(photo, photo_request(args))
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
    groups = (
        [(pen, layers) for pen, layers in plan.pen_runs()]
        if len(plan.pens) > 1
        else [(layer.name, (layer,)) for layer in plan.layers]
    )
    for name, layers in groups:
        lines = [
            path if len(path) > 1 else np.vstack([path, path]) for layer in layers for path in layer.paths
        ]
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


pencilbot.help_group = "Plugins"  # type: ignore[attr-defined]  # vpype's --help reads it
