"""shadowgame: several tight shadow maps per light, and linear-light soft shadows, measured
against a ray tracer.

The packages, bottom to top; each imports only from those below it (tests/test_imports.py):

- ``errors``, ``transforms``, ``data``: the one error type, matrix conventions, data folders;
- ``scene``: the scene model, its file format, shapes, towns, packed triangles;
- ``gpu``: the GL context, limits, timing, the shader preprocessor, the blocks, the depth array;
- ``reference``: the Embree ground truth, reading only dumps;
- ``shadows``: the hard-shadow methods, which plan maps;
- ``soft``: the linear light's compute tracer and the soft composite;
- ``render``: the passes that draw a frame, and the renderer that runs them;
- ``app``: capture, trace, dumps and safe outputs, and the walkaround window;
- ``bench``: the speed-versus-accuracy benchmark and its charts;
- ``cli``: the command line.
"""
