"""The link layer: the one rosbridge connection and the client web processes use to reach it."""
