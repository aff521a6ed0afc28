"""Map overlays: the laser, costmaps, particles, footprint and local plan, made ready for the map page."""
