"""A head on the neck: what a hood rests on.

The mannequin is a dress form: its neck ends in a flat cap 7.5 cm above the nape, and a
hood placed round the head of the body it was drafted for has nothing to rest on (it
stands on the neck stump and crumples). A head is an option of the mannequin
(``build_mannequin(head_length_cm=...)``): an ellipsoid set on the neck, sized by one
length, the crown's height above the nape (GarmentCode's ``head_l``, 26.3 cm on its mean
body). It is a closed surface of its own, its base sunk 1.5 cm into the neck (the jaw and
the back of the skull overhang the neck, as on a body); the torso's measurements, landmarks
and feature lines do not change.

Proportions of an adult head (breadth : depth : height above the neck about 0.72 : 0.92 : 1)
scale with the length given.
"""

from __future__ import annotations

import numpy as np
import trimesh

from sandbox.mannequin.shape import BodyShape

#: the head's base below the neck's top cap [m] (the neck top is 7.5 cm above the nape)
BASE_ABOVE_NAPE_M = 0.06
BREADTH_RATIO = 0.72  # head breadth / head height
DEPTH_RATIO = 0.92  # head depth (front to back) / head height
FORWARD_M = 0.012  # the head's centre in front of the neck's centre line [m]
#: the range of head lengths accepted [cm]: crown above the nape
HEAD_LENGTH_RANGE_CM = (18.0, 35.0)
SUBDIVISIONS = 3  # icosphere subdivisions: 642 vertices, 1,280 triangles


def head_mesh(shape: BodyShape, head_length_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (k, 3) [m] and outward triangles (t, 3) of a head whose crown is
    ``head_length_m`` above the nape of ``shape``."""
    height = float(head_length_m) - BASE_ABOVE_NAPE_M  # base to crown
    sphere = trimesh.creation.icosphere(subdivisions=SUBDIVISIONS)
    semi = 0.5 * height * np.array([BREADTH_RATIO, 1.0, DEPTH_RATIO])
    centre = np.array([0.0, shape.y_nape + BASE_ABOVE_NAPE_M + 0.5 * height,
                       shape.neck_z + FORWARD_M])  # fmt: skip
    v = np.asarray(sphere.vertices, float) * semi + centre
    return v, np.asarray(sphere.faces, np.int64)
