"""The application layer: what every front door (the CLI's commands, the studio, the vpype
plugin, the library API) calls for photo → plan → program, with every guard in it once.

:mod:`.photo` a photo's request, its guards and its plan; :mod:`.photo_options` the photo options
of a command line, read back as a request; :mod:`.program` a plan's program for a plotter.
"""
