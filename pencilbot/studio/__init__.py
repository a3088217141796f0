"""``pencilbot studio``: a local web page to make a drawing and watch it plot.

The page (plain HTML, CSS and JavaScript in ``static/``, served from the package, no CDN) talks
to a Starlette app (:mod:`.app`) run by uvicorn (:mod:`.server`). The web layer only calls the
library: :func:`pencilbot.app.photo.sketch_and_plan` in a worker process (:mod:`.planner`, newest change
wins), the exporters for downloads, and :func:`pencilbot.api.draw` in a thread per plotter
(:mod:`.plotting`), whose progress records and prompts it shows. :mod:`.guard` keeps other
sites and other hosts out. Installed with the ``studio`` extra (``pip install pencilbot[studio]``).
"""
