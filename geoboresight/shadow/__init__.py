"""The shadow application (paper §3.1): boresight shadow classes and mask, scene-adaptive shadow
cluster, shadow-fraction model, ground-truth illumination from a surface model, a dark-pixel
baseline, and shadow polygons."""
