"""The honeycomb cell: its hexagonal geometry and wall mesh, patches and rows of cells, and the packings inside."""
