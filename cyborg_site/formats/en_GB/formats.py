"""Times in 24 hours everywhere Django formats them (the admin's lists and forms): robot logs,
the pages and ROS tools all use 24-hour times, and a "4:03 p.m." beside "16:03:12" reads as two clocks."""

DATE_FORMAT = "j M Y"
TIME_FORMAT = "H:i:s"
DATETIME_FORMAT = "j M Y, H:i:s"
SHORT_DATE_FORMAT = "Y-m-d"
SHORT_DATETIME_FORMAT = "Y-m-d H:i"
