"""Experiments built from the stages: the paper's runs (:mod:`.paper`) and the demo (:mod:`.demo`).

They use the library as a user would; nothing in the library imports them.
"""
