"""This folder on the import path: the tests share the sweep (``sweep.py``) with bench/hostile.py."""
