"""The walker's report and pictures: analysis results → HTML, PNG, GIF, 3D scenes.

Takes gait results and walkers. Gives :mod:`.writer` (the main job's report), :mod:`.page` (its
HTML building blocks and the player), :mod:`.figures`, :mod:`.animation`, :mod:`.view3d` (the
walk as a 3D scene), :mod:`.labels` (readable names and units), :mod:`.comparison` (the
published numbers the report checks against) and :mod:`.display` (a GaitResult in a notebook).
"""
