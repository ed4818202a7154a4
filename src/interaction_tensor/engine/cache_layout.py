"""The neighbour cache's page layout, shared by the Numba kernels and their Python side.

Root blocks' entries are kept in pages of PAGE^3 blocks (PAGE = 2^PAGE_BITS), allocated where a
block is built: a person's keypoints reach far past the scene, and a dense table over that box
took more of the cache's budget than its trees (26 of 48 MB, living-room4). The values are
compiled into the Numba kernels: clear their cache after a change.
"""

PAGE_BITS = 2
PAGE = 1 << PAGE_BITS
