"""The front door: a rosbridge v2 endpoint through which other ROS tools (roslibjs pages, roslibpy
scripts, Foxglove's and Lichtblick's Rosbridge connection) reach the robot, with the product's login,
roles, drive lock, E-STOP latch and audit, and one upstream subscription per topic shared with the pages.

``tickets`` lets a tool in, ``protocol`` reads and writes the frames, ``rules`` says what a person may
publish or call and runs it through the command pipeline, ``session`` is one tool's connection,
``encoding`` and ``rawtypes`` make the CBOR and ``cbor-raw`` frames Foxglove and Lichtblick ask for.
"""

SOCKET_PATH = "/rosbridge/"  # where tools connect (?ticket=…)
