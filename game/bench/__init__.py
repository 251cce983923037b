"""The benchmark: the sweep's runs, their measurement against the Embree reference, the CSV, the
acceptance figures, the charts, the stability scenes and the soft-shadow sweep.

May import ``game.app`` and every layer below it.
"""
