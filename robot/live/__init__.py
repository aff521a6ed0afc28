"""Live state: the latest-state store, group and key names, and the one store-and-announce path."""
