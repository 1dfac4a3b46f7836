"""Data: BVH files and datasets in, fixed-length windows, the network's state features and phase labels out."""
