"""Command-line front end of sizefx (installed as ``sizefx_cli``)."""
