"""The collision shapes a geometry can have, and the integer codes the compiled collision kernels
read.

Every shape sits in its own frame {g}; `size` is a (3,) row whatever the shape, with unused
entries zero (lengths in metres):

  SPHERE     (r, 0, 0)        centred at the origin of {g}
  BOX        (x, y, z)        full edge lengths, as in the URDF's <box size>, centred
  CYLINDER   (r, length, 0)   axis along z_g, centred
  CAPSULE    (r, length, 0)   the segment of that length along z_g, centred, swept by a ball of r
  MESH       (sx, sy, sz)     the scale of a mesh file; the shape is the convex hull of its
                              vertices, already scaled, in {g}
  HALFSPACE  (0, 0, 0)        the solid z_g <= 0, bounded by the plane through the origin of {g}
                              whose normal is z_g (the ground, a table top, a wall)
"""

SPHERE, BOX, CYLINDER, CAPSULE, MESH, HALFSPACE = range(6)

SHAPE_NAMES = ("sphere", "box", "cylinder", "capsule", "mesh", "halfspace")
"""The shapes' names, indexed by their codes (`SHAPE_NAMES[BOX] == "box"`)."""
