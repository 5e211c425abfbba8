"""How reflected objects are stood in for: one module per method (depth images, cube maps,
billboards, simplified and real triangles, the hybrid), and the parts they share (the atlas of
baked images, the bounce images of mirrors in mirrors, the depth pyramids, the BVH)."""
