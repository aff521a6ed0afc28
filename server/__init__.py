"""The web server: what puts the site together and runs it under Daphne (the top of the layers).

``asgi`` composes the apps' routes behind the ASGI middleware here, ``urls`` is
the site's URL map, and ``patches`` holds every change to Daphne's, Twisted's and autobahn's internals.
"""
