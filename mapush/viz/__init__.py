"""Pictures of a run: MP4 videos rendered headless with MuJoCo's own renderer, and the viewer's scene overlays.

`preflight` runs before MuJoCo is imported (it picks the OpenGL backend); `scene` and `video` need MuJoCo.
"""
