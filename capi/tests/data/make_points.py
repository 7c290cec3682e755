"""Writes grid-100.pts: a 5 x 5 x 4 grid of points 0.25 apart, point i at
((i % 5) / 4, (i // 5 % 5) / 4, (i // 25) / 4), so queries meet equal
distances (ties go to the lower index)."""
import struct

with open("grid-100.pts", "wb") as f:
    for i in range(100):
        f.write(struct.pack("<3f", (i % 5) / 4, (i // 5 % 5) / 4, (i // 25) / 4))
