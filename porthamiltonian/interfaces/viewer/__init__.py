"""An interactive 3D view of rigid-body motion, and its still image (an interfaces-layer
package: nothing in the numeric layers imports it).

A :class:`Scene` holds bodies drawn with shapes (:class:`Sphere`, :class:`Capsule`,
:class:`Cylinder`, :class:`Box`, :class:`TorusArc`), their poses over time (positions and unit
quaternions, world frame), the :class:`Ground` (a plane, a slope, a step), force
:class:`Arrow` s and stride boundaries. ``scene.to_html(path)`` writes a self-contained page
(three.js, vendored in ``vendor/three``, inline: it works offline) with orbit, play/pause, a
slider and stride stepping; ``scene.to_png(path)`` a still image (matplotlib, the ``plots``
extra). :func:`scene_from_trajectory` builds a scene from a simulation of any model that outputs
body poses (:mod:`.from_trajectory` says which names it reads).
"""
from .from_trajectory import pose_sources, scene_from_trajectory
from .scene import Arrow, Body, Ground, Scene
from .shapes import Box, Capsule, Cylinder, Shape, Sphere, TorusArc

__all__ = ["Arrow", "Body", "Box", "Capsule", "Cylinder", "Ground", "Scene", "Shape", "Sphere",
           "TorusArc", "pose_sources", "scene_from_trajectory"]
