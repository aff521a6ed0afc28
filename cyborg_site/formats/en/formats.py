from cyborg_site.formats.en_GB.formats import *  # noqa: F403  (the same 24-hour times for plain "en")
