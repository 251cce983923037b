"""One module per hard-shadow method, each a :class:`~game.shadows.method.ShadowMethod`.

``clumped`` is the multi-map method; ``single``, ``static-dynamic`` and ``csm`` are the maps
engines ship; ``traced`` is exact, from the compute tracer. :mod:`game.shadows.registry` lists
them.
"""
