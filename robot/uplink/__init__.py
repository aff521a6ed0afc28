"""The robot dials out: the server's end of the uplink agent's connection (see ``uplink_agent``).

``endpoint`` takes the agent's connection (credentials, limits, one per robot, audit), ``tunnel``
carries channels over it, ``relays`` gives the link and the video relay loopback addresses that
open those channels, so both speak to the robot as if they had dialled it.
"""
