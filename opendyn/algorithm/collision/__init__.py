"""The collision narrow phase: signed distances, nearest points and normals of convex shapes
(opendyn.multibody.shapes), compiled and allocation-free.

  vectors.py       3-vectors as tuples, poses T = [R p]
  support.py       support functions of every shape (sphere and capsule by their cores)
  simplex.py       the simplex's point nearest the origin (GJK's sub-algorithm)
  gjk.py           GJK: the distance of separated shapes
  epa.py           EPA: the penetration depth, normal and points of overlapping shapes
  closed_forms.py  sphere and capsule pairs, sphere-box, anything against a halfspace
  box_box.py       two overlapping boxes by the separating-axis theorem
  narrow_phase.py  pair_distance: the dispatch by shape codes
  clipping.py      polygon clipping and the reduction of a manifold to four points
  manifold.py      up to four contact points of a shape against a halfspace
  box_manifold.py  up to four contact points of two boxes (clipping)
  features.py      the face, edge or point of a shape farthest along a direction
  face_contacts.py up to four contact points of any two shapes face-on or edge-on (clipping)
"""

from .box_manifold import box_contacts
from .closed_forms import DISTANCE, NORMAL, OUT_SIZE, POINT_A, POINT_B
from .face_contacts import face_contacts
from .manifold import MAX_CONTACTS, halfspace_contacts
from .narrow_phase import mesh_hull, no_hull, pair_distance, work_array

__all__ = [
    "DISTANCE",
    "MAX_CONTACTS",
    "NORMAL",
    "OUT_SIZE",
    "POINT_A",
    "POINT_B",
    "box_contacts",
    "face_contacts",
    "halfspace_contacts",
    "mesh_hull",
    "no_hull",
    "pair_distance",
    "work_array",
]
