"""Map and navigation: the rendered map, goals, initial pose and named locations."""
