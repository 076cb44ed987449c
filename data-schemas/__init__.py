"""File contracts of sizefx (installed as ``sizefx.schemas``).

The JSON files next to this one are read by :mod:`sizefx.io.schema`; readers and
writers take dataset names, shapes, dtypes and units from them and nowhere else.
"""
