"""Tests mirror the package; fixtures in conftest.py."""
