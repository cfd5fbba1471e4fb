"""The vision front end: calibration, rectification, NCC stereo, segmentation, lines -> evidence."""
