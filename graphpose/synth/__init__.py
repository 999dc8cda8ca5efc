"""Synthetic images with exact truth: single renders (:mod:`.render`) and hand-held
sequences (:mod:`.sequence`)."""
