"""Synthetic images with exact truth: single renders (:mod:`.render`, on the exact areas of
:mod:`.raster`), random poses and polygons (:mod:`.poses`), the junctions' Cramer-Rao bound
(:mod:`.information`) and hand-held sequences (:mod:`.sequence`)."""
