"""Every setting comes from the environment (see README, "Configuration")."""

from __future__ import annotations

import os
import secrets
import tempfile
from datetime import timedelta
from pathlib import Path
from typing import Any

import dj_database_url
from redis.asyncio.retry import Retry
from redis.backoff import NoBackoff
from redis.exceptions import ConnectionError as RedisConnectionError

from cyborg_site.env import (
    env_bool,
    env_choice,
    env_float,
    env_int,
    env_json_dict,
    env_list,
    env_pair,
    env_str,
)

BASE_DIR = Path(__file__).resolve().parent.parent
VAR_DIR = Path(env_str("VAR_DIR", str(BASE_DIR / "var")))
# Audit entries the database could not take wait here until it can (robot.commands.audit_journal).
AUDIT_JOURNAL_DIR = Path(env_str("AUDIT_JOURNAL_DIR", str(VAR_DIR / "audit-journal")))

DEBUG = env_bool("DEBUG", False)
SECRET_KEY = env_str("SECRET_KEY") or ("insecure-dev-key-only-for-local-use" if DEBUG else "")
if not SECRET_KEY:
    # Local runs without DEBUG still get a stable key, kept beside the database.
    _key_file = VAR_DIR / "secret_key"
    if not _key_file.exists():
        import contextlib
        import secrets

        VAR_DIR.mkdir(parents=True, exist_ok=True)
        with contextlib.suppress(FileExistsError):  # another process made it first: read that one
            with os.fdopen(os.open(_key_file, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600), "w") as key_out:
                key_out.write(secrets.token_urlsafe(50))
    SECRET_KEY = _key_file.read_text().strip()
ALLOWED_HOSTS = env_list("ALLOWED_HOSTS", ["127.0.0.1", "localhost", "[::1]"])
CSRF_TRUSTED_ORIGINS = env_list("CSRF_TRUSTED_ORIGINS", [])

# --- Behind TLS (production): all off by default so a local http run works --------------
SECURE_SSL_REDIRECT = env_bool("SECURE_SSL_REDIRECT", False)
SECURE_HSTS_SECONDS = env_int("SECURE_HSTS_SECONDS", 0, minimum=0)
SECURE_HSTS_INCLUDE_SUBDOMAINS = env_bool("SECURE_HSTS_INCLUDE_SUBDOMAINS", False)
SECURE_HSTS_PRELOAD = env_bool("SECURE_HSTS_PRELOAD", False)
SESSION_COOKIE_SECURE = env_bool("SESSION_COOKIE_SECURE", False)
CSRF_COOKIE_SECURE = env_bool("CSRF_COOKIE_SECURE", False)
# A TLS-terminating proxy in front: "HTTP_X_FORWARDED_PROTO,https" (only if the proxy sets it).
SECURE_PROXY_SSL_HEADER = env_pair("SECURE_PROXY_SSL_HEADER")
# The health check stays reachable over plain http from the load balancer.
SECURE_REDIRECT_EXEMPT = [r"^healthz$"]

INSTALLED_APPS = [
    "daphne",
    "django.contrib.admin",
    "django.contrib.auth",
    "django.contrib.contenttypes",
    "django.contrib.sessions",
    "django.contrib.messages",
    "django.contrib.staticfiles",
    "channels",
    "rest_framework",
    "rest_framework.authtoken",
    "drf_spectacular",
    "drf_spectacular_sidecar",
    "axes",
    "robot",
    "robot.alerts",
    "dashboard",
    "history",
    "server",
]

MIDDLEWARE = [
    "django.middleware.security.SecurityMiddleware",
    "cyborg_site.csp.ContentSecurityPolicyMiddleware",
    "whitenoise.middleware.WhiteNoiseMiddleware",
    "django.contrib.sessions.middleware.SessionMiddleware",
    "django.middleware.common.CommonMiddleware",
    "django.middleware.csrf.CsrfViewMiddleware",
    "django.contrib.auth.middleware.AuthenticationMiddleware",
    # An operator's signed E-STOP pass, for pressing it while the database is down.
    "robot.estop.access.EstopPassMiddleware",
    # Who changed an account, a role, a token or a setting (dashboard.access_audit).
    "dashboard.access_audit.ActorMiddleware",
    # The browser an account logged in from, let in while that account is flooded (dashboard.login_flood).
    "dashboard.login_flood.DeviceCookieMiddleware",
    # Each signed-in session's "last seen", for its person's account page (dashboard.sessions).
    "dashboard.sessions.SessionSeenMiddleware",
    "django.contrib.messages.middleware.MessageMiddleware",
    "django.middleware.clickjacking.XFrameOptionsMiddleware",
    "dashboard.middleware.LoginRequiredMiddleware",
    # Last: turns a lockout flagged during authentication into the lockout answer.
    "axes.middleware.AxesMiddleware",
]

ROOT_URLCONF = "server.urls"
ASGI_APPLICATION = "server.asgi.application"
WSGI_APPLICATION = None

TEMPLATES = [
    {
        "BACKEND": "django.template.backends.django.DjangoTemplates",
        "DIRS": [BASE_DIR / "templates"],
        "APP_DIRS": True,
        "OPTIONS": {
            "context_processors": [
                "django.template.context_processors.request",
                "django.contrib.auth.context_processors.auth",
                "django.contrib.messages.context_processors.messages",
                "dashboard.context_processors.roles",
                "dashboard.context_processors.site_config",
                "dashboard.context_processors.estop",
            ],
        },
    },
]

DATABASES = {
    "default": dj_database_url.parse(
        env_str("DATABASE_URL", f"sqlite:///{VAR_DIR / 'db.sqlite3'}"),
        conn_max_age=env_int("DATABASE_CONN_MAX_AGE", 0, minimum=0),
    )
}
# (Not Django's psycopg pool: a connection belongs to a thread, and the pool counts one a short-lived
# worker thread never closed as taken for good; the suite's services pass ran it dry within minutes.)
if DATABASES["default"]["ENGINE"] == "django.db.backends.sqlite3":
    # WAL lets the recorder write while pages read; a busy timeout instead of "database is locked".
    # Transactions take the write lock when they begin: a deferred one that read first cannot
    # wait for it (SQLite refuses the upgrade at once if another connection wrote meanwhile).
    DATABASES["default"].setdefault("OPTIONS", {}).update(
        {"timeout": 20, "transaction_mode": "IMMEDIATE",
         "init_command": "PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL;"}
    )
    # Tests use a file, not shared-cache memory: there, background threads (recorder, link)
    # get "table is locked" at once instead of waiting out the busy timeout.
    DATABASES["default"]["TEST"] = {"NAME": str(VAR_DIR / f"test-{os.getpid()}.sqlite3")}
DEFAULT_AUTO_FIELD = "django.db.models.BigAutoField"

# Every password set through the product (adduser, the admin, a password change) passes these.
AUTH_PASSWORD_VALIDATORS = [
    {"NAME": "django.contrib.auth.password_validation.UserAttributeSimilarityValidator"},
    {"NAME": "django.contrib.auth.password_validation.MinimumLengthValidator",
     "OPTIONS": {"min_length": 12}},
    {"NAME": "django.contrib.auth.password_validation.CommonPasswordValidator"},
    {"NAME": "django.contrib.auth.password_validation.NumericPasswordValidator"},
]
AUTHENTICATION_BACKENDS = [
    "axes.backends.AxesStandaloneBackend",  # refuses locked-out accounts and addresses first
    "dashboard.login_flood.FloodGuardBackend",  # then a flooded account, but from its owner's browser
    "django.contrib.auth.backends.ModelBackend",
]
# Login throttling (login form and API token): after LOGIN_FAILURE_LIMIT failures for one account
# from one address, that account is refused from that address, and after as many from one address
# (whatever the accounts), that address is refused, for LOGIN_LOCKOUT_MINUTES (admins can clear it
# under Admin → Axes → Access attempts). Never an account from everywhere: anyone could then keep
# the operators from logging in to press the E-STOP.
AXES_FAILURE_LIMIT = env_int("LOGIN_FAILURE_LIMIT", 5, minimum=1)
AXES_COOLOFF_TIME = timedelta(minutes=env_float("LOGIN_LOCKOUT_MINUTES", 15.0, minimum=0.1))
AXES_LOCKOUT_PARAMETERS = [["username", "ip_address"], "ip_address"]
AXES_RESET_ON_SUCCESS = True
# An account with this many failures (from anywhere) within LOGIN_LOCKOUT_MINUTES takes a password only
# from a browser it logged in from before (dashboard.login_flood).
LOGIN_FLOOD_LIMIT = env_int("LOGIN_FLOOD_LIMIT", 20, minimum=1)
AXES_LOCKOUT_CALLABLE = "dashboard.lockouts.lockout_response"
AXES_CLIENT_IP_CALLABLE = "dashboard.lockouts.client_ip"
AXES_VERBOSE = False
# API tokens expire this many days after they were made (0: never); a password change ends them.
API_TOKEN_DAYS = env_float("API_TOKEN_DAYS", 30.0, minimum=0.0)
# The reverse proxies (addresses or networks) whose X-Forwarded-For and X-Forwarded-Proto are
# believed: the client address of lockouts, throttles and the audit (cyborg_site.client_address).
TRUSTED_PROXIES = env_list("TRUSTED_PROXIES", [])
# Single sign-on with the organisation's OpenID Connect provider (dashboard.sso), beside the local
# accounts; unset OIDC_ISSUER: local accounts only. Register SITE/accounts/sso/callback/ as the
# redirect URL. OIDC_ROLES maps claim values of OIDC_ROLE_CLAIM (or, written @domain, a verified
# e-mail domain) to roles: "cyborg-operators=operator @ntnu.no=viewer"; the highest match wins, and
# a person matching none gets OIDC_DEFAULT_ROLE, or is refused when that is empty.
OIDC_ISSUER = env_str("OIDC_ISSUER")
OIDC_CLIENT_ID = env_str("OIDC_CLIENT_ID")
OIDC_CLIENT_SECRET = env_str("OIDC_CLIENT_SECRET")
OIDC_SCOPES = env_str("OIDC_SCOPES", "openid profile email")
OIDC_NAME = env_str("OIDC_NAME", "your organisation")
OIDC_ROLE_CLAIM = env_str("OIDC_ROLE_CLAIM", "groups")
OIDC_ROLES = env_str("OIDC_ROLES")
OIDC_DEFAULT_ROLE = env_str("OIDC_DEFAULT_ROLE")
OIDC_LEEWAY_S = env_int("OIDC_LEEWAY_S", 30, minimum=0)  # clock skew allowed on the ID token's times
# Only superusers and accounts given "May sign in with a local password" (Admin → Users) may then
# use the login form; tokens for scripts work as before.
SSO_REQUIRED = env_bool("SSO_REQUIRED", False)
LOGIN_URL = "login"
LOGIN_REDIRECT_URL = "dashboard:home"
LOGOUT_REDIRECT_URL = "login"

LANGUAGE_CODE = "en-gb"
FORMAT_MODULE_PATH = ["cyborg_site.formats"]  # 24-hour times (cyborg_site/formats/en_GB/formats.py)
TIME_ZONE = env_str("TIME_ZONE", "Europe/Oslo")
USE_I18N = True
USE_TZ = True

STATIC_URL = "static/"
STATICFILES_DIRS = [BASE_DIR / "static"]
STATIC_ROOT = VAR_DIR / "staticfiles"
# Serve straight from the app and project static folders: no collectstatic step to forget.
WHITENOISE_USE_FINDERS = True
WHITENOISE_AUTOREFRESH = DEBUG
# Production: collectstatic writes content-hashed names that nginx serves with year-long caching.
if env_bool("STATIC_HASHED", False):
    STORAGES = {
        "default": {"BACKEND": "django.core.files.storage.FileSystemStorage"},
        "staticfiles": {"BACKEND": "django.contrib.staticfiles.storage.ManifestStaticFilesStorage"},
    }

# --- Redis: channel layer, Celery broker, latest-state store, queues, locks, live feed --------
# Unset, the embedded default: a private Valkey server of this process's own (robot.live.private_server),
# started on first use on a unix socket in a fresh directory. Either way the same Redis code runs.
EMBEDDED = not env_str("REDIS_URL")  # one process hosts the web server, the robot link and the periodic work
REDIS_URL = env_str("REDIS_URL") or (
    f"unix://{tempfile.gettempdir()}/cyborg-valkey-{os.getpid()}-{secrets.token_hex(4)}/valkey.sock")

CHANNEL_LAYERS: dict[str, dict[str, Any]] = {
    "default": {
        # channels_redis's layer, starting the private server first when it is the one configured.
        "BACKEND": "robot.live.channel_layer.RedisChannelLayer",
        "CONFIG": {
            # redis-py 8 times socket reads out after 5 s by default, exactly the layer's blocking
            # receive (BZPOPMIN, 5 s): a quiet channel then raised TimeoutError out of receive().
            # After a Redis restart its pooled connections are dead: pinged when idle, and a command
            # that meets one tries again on a fresh one (as robot.live.redis_clients does).
            "hosts": [{"address": REDIS_URL, "socket_timeout": 15, "socket_connect_timeout": 2,
                       "health_check_interval": 2,
                       "retry": Retry(NoBackoff(), 1, supported_errors=(RedisConnectionError,))}],
            "prefix": env_str("CHANNEL_LAYER_PREFIX", "cyborg"),
            "capacity": 200,
            "expiry": 10,
        },
    }
}
# Celery's queues under the same prefix as everything else, so deployments can share one Redis.
CELERY_BROKER_TRANSPORT_OPTIONS = {"global_keyprefix": f"{CHANNEL_LAYERS['default']['CONFIG']['prefix']}:celery:"}
# The embedded default runs no worker: its periodic work runs in the process (history.retention).
CELERY_BROKER_URL = "memory://" if EMBEDDED else REDIS_URL
CELERY_RESULT_BACKEND = None if EMBEDDED else REDIS_URL
CELERY_TASK_ALWAYS_EAGER = False
CELERY_TASK_IGNORE_RESULT = True
CELERY_TIMEZONE = "UTC"
CELERY_BROKER_CONNECTION_RETRY_ON_STARTUP = True

# --- The robot -------------------------------------------------------------------------
# UPLINK=true: the robot dials in (its uplink agent, through nginx at /uplink/) instead of being dialled.
# The process that hosts the link then listens for the agent on UPLINK_LISTEN, and the link and the video
# relay reach the robot through loopback relays on UPLINK_ROSBRIDGE_PORT and UPLINK_VIDEO_PORT (robot.uplink).
UPLINK = env_bool("UPLINK", False)
UPLINK_LISTEN = env_str("UPLINK_LISTEN", "127.0.0.1:8770")
UPLINK_ROSBRIDGE_PORT = env_int("UPLINK_ROSBRIDGE_PORT", 8771, minimum=1)
UPLINK_VIDEO_PORT = env_int("UPLINK_VIDEO_PORT", 8772, minimum=1)
UPLINK_ROBOT = env_str("UPLINK_ROBOT", "cyborg")  # the robot whose credentials this server takes
UPLINK_MAX_FRAME_BYTES = env_int("UPLINK_MAX_FRAME_BYTES", 64 * 1024 * 1024, minimum=1024)
UPLINK_MAX_MESSAGES_PER_S = env_int("UPLINK_MAX_MESSAGES_PER_S", 5000, minimum=10)
UPLINK_AUTH_TIMEOUT_S = env_float("UPLINK_AUTH_TIMEOUT_S", 5.0, minimum=0.1)
UPLINK_FAILURE_LIMIT = env_int("UPLINK_FAILURE_LIMIT", 10, minimum=1)  # refused attempts per address and minute
ROSBRIDGE_URL = env_str("ROSBRIDGE_URL", f"ws://127.0.0.1:{UPLINK_ROSBRIDGE_PORT}" if UPLINK else "ws://127.0.0.1:9090")
# A wss:// robot's certificate is checked against these roots (PEM), or the system's when unset.
ROSBRIDGE_CA_FILE = env_str("ROSBRIDGE_CA_FILE", "")
VIDEO_URL = env_str("VIDEO_URL", f"http://127.0.0.1:{UPLINK_VIDEO_PORT}" if UPLINK else "http://127.0.0.1:8080")
VIDEO_TOPIC = env_str("VIDEO_TOPIC", "/videostream")
# Camera streams one web process serves at once: per person, and in all.
CAMERA_STREAMS_PER_PERSON = env_int("CAMERA_STREAMS_PER_PERSON", 3, minimum=1)
CAMERA_STREAMS_TOTAL = env_int("CAMERA_STREAMS_TOTAL", 50, minimum=1)
# Which ROS the robot runs: 1, 2, or auto (the link asks /rosapi/get_ros_version, which only ROS 2 serves).
ROBOT_ROS = env_str("ROBOT_ROS", "auto")
# Re-wiring: {"topics": {"cmd_vel": "/RosAria/cmd_vel"}, "services": {...}, "actions": {...}}
_names = env_json_dict("ROBOT_NAME_OVERRIDES")
ROBOT_TOPICS: dict[str, str] = _names.get("topics", {})
ROBOT_SERVICES: dict[str, str] = _names.get("services", {})
ROBOT_ACTIONS: dict[str, str] = _names.get("actions", {})
# Reconnect attempts back off up to this (the link also retries at once when rosbridge's port listens again).
ROBOT_LINK_MAX_BACKOFF_S = env_float("ROBOT_LINK_MAX_BACKOFF_S", 2.0, minimum=0.5)
# Scaled mode: robot links share a Redis lease this long (renewed 4x as often); a standby takes over
# at most this long after the holder dies. ROBOT_LINK_NAME names this process in the lease and health.
ROBOT_LINK_LEASE_S = env_float("ROBOT_LINK_LEASE_S", 2.0, minimum=0.5)
ROBOT_LINK_NAME = env_str("ROBOT_LINK_NAME", "")
# Scaled mode: the links' second path for the E-STOP, beside Redis (robot.link.direct): one host:port
# per link process, the same list for every process; each link listens on the first one free.
ROBOT_LINK_DIRECT_ADDRESSES = env_list("ROBOT_LINK_DIRECT_ADDRESSES", [])
# A robotlink told to stop (SIGTERM) exits within this, its threads' stacks in its log if it had to cut its
# stop short: inside the supervisor's kill timeout (scripts/stack.sh 10 s, systemd TimeoutStopSec 15 s).
ROBOT_LINK_STOP_DEADLINE_S = env_float("ROBOT_LINK_STOP_DEADLINE_S", 8.0, minimum=0.01)
ROBOT_REQUEST_TIMEOUT_S = env_float("ROBOT_REQUEST_TIMEOUT_S", 5.0, minimum=0.1)
# A topic no page watches or shows (the topics page, a map overlay) and nobody records keeps its upstream
# subscription this long before the link lets go; a watched topic reaches pages at most this often.
TOPICS_IDLE_GRACE_S = env_float("TOPICS_IDLE_GRACE_S", 5.0, minimum=0)
TOPICS_ECHO_MAX_HZ = env_float("TOPICS_ECHO_MAX_HZ", 20.0, minimum=0.5)
# The rosbridge front door for other ROS tools (robot.frontdoor): a connect ticket works once, this soon;
# a client asking no throttle gets the robot's high-rate topics this often (per topic in the admin);
# browsers' origins accepted besides the site's own (a Foxglove or Lichtblick web app, a roslibjs page).
FRONTDOOR_TICKET_S = env_float("FRONTDOOR_TICKET_S", 30.0, minimum=1)
FRONTDOOR_PACE_HZ = env_float("FRONTDOOR_PACE_HZ", 10.0, minimum=0.1)
FRONTDOOR_ORIGINS = env_list("FRONTDOOR_ORIGINS", [])
# Values older than this are shown as stale (greyed) on the pages.
STALE_AFTER_S = env_float("STALE_AFTER_S", 10.0, minimum=0.5)
BATTERY_LOW_PERCENT = env_float("BATTERY_LOW_PERCENT", 20.0, minimum=0)
# A connected robot that says nothing (no message, no rosapi answer) for this long is "not responding".
ROBOT_HANG_S = env_float("ROBOT_HANG_S", 2.0, minimum=0.5)
# Alerts beyond the tab (robot.alerts.delivery): Web Push with VAPID (a key pair is generated into
# VAR_DIR/vapid_private.pem when none is given), e-mail through Django's mail, webhooks from the admin.
VAPID_PRIVATE_KEY_FILE = env_str("VAPID_PRIVATE_KEY_FILE", "")
VAPID_SUBJECT = env_str("VAPID_SUBJECT", "mailto:cyborg@localhost")
EMAIL_HOST = env_str("EMAIL_HOST", "localhost")
EMAIL_PORT = env_int("EMAIL_PORT", 25, minimum=1)
EMAIL_HOST_USER = env_str("EMAIL_HOST_USER", "")
EMAIL_HOST_PASSWORD = env_str("EMAIL_HOST_PASSWORD", "")
EMAIL_USE_TLS = env_bool("EMAIL_USE_TLS", False)
EMAIL_TIMEOUT = 10
DEFAULT_FROM_EMAIL = env_str("DEFAULT_FROM_EMAIL", "Cyborg Commander <cyborg@localhost>")
# Embedded default: host the link inside the Daphne process (off only for special setups).
ROBOT_LINK_EMBEDDED = env_bool("ROBOT_LINK_EMBEDDED", True)

# --- Commanding ------------------------------------------------------------------------
MODE_COMMANDER = env_choice("MODE_COMMANDER", "server", ("server", "robot"))
COMMAND_THROTTLE_RATE = env_str("COMMAND_THROTTLE_RATE", "120/min")
# Reads (GET) per caller and web process, bursts allowed; a faster caller waits, then 429 (0: off).
READ_THROTTLE_PER_S = env_float("READ_THROTTLE_PER_S", 20.0, minimum=0)
READ_THROTTLE_BURST = env_float("READ_THROTTLE_BURST", 40.0, minimum=1)
READ_THROTTLE_WAIT_S = env_float("READ_THROTTLE_WAIT_S", 1.0, minimum=0)
# The page flags "requested X, state machine in Y" once a mode request is this old.
MODE_MISMATCH_GRACE_S = env_float("MODE_MISMATCH_GRACE_S", 3.0, minimum=0.5)

# --- Map and navigation ----------------------------------------------------------------
NAVIGATION_BACKEND = env_choice("NAVIGATION_BACKEND", "move_base", ("move_base", "cyborg_navigation"))

# --- Teleop and video ------------------------------------------------------------------
TELEOP_RATE_HZ = env_float("TELEOP_RATE_HZ", 10.0, minimum=1)
TELEOP_DEADMAN_S = env_float("TELEOP_DEADMAN_S", 0.5, minimum=0.05)
TELEOP_MAX_LINEAR = env_float("TELEOP_MAX_LINEAR", 0.5, minimum=0)
TELEOP_MAX_ANGULAR = env_float("TELEOP_MAX_ANGULAR", 1.0, minimum=0)
# The drive lock frees itself after this long without input (a driver who walked away).
TELEOP_LOCK_TTL_S = env_float("TELEOP_LOCK_TTL_S", 30.0, minimum=1)
# The link publishes zero itself when moving Twists stop arriving for this long (a web process died).
TELEOP_LINK_DEADMAN_S = env_float("TELEOP_LINK_DEADMAN_S", 0.35, minimum=0.05)
# After an E-STOP the link keeps publishing zero at the teleop rate for this long.
ESTOP_HOLD_S = env_float("ESTOP_HOLD_S", 1.0, minimum=0)

# --- Two-way audio ---------------------------------------------------------------------
# A talker whose audio stops arriving for this long is cut (push-to-talk let go, tab frozen).
# Chunks come every 20 ms; 0.3 s leaves room for a loaded server to still cut within 0.5 s.
AUDIO_TALK_QUIET_S = env_float("AUDIO_TALK_QUIET_S", 0.3, minimum=0.05)
# The talk lock frees itself this long after its last refresh (a web process died mid-talk).
AUDIO_TALK_LOCK_TTL_S = env_float("AUDIO_TALK_LOCK_TTL_S", 3.0, minimum=0.5)

# --- History ---------------------------------------------------------------------------
HISTORY_DEFAULT_INTERVAL_S = env_float("HISTORY_DEFAULT_INTERVAL_S", 5.0, minimum=0.1)
HISTORY_MAX_MESSAGE_BYTES = env_int("HISTORY_MAX_MESSAGE_BYTES", 256 * 1024, minimum=1)
# The recorder writes what it keeps at most this long after it arrives, in batches.
HISTORY_FLUSH_S = env_float("HISTORY_FLUSH_S", 0.5, minimum=0.01)
HISTORY_BATCH_ROWS = env_int("HISTORY_BATCH_ROWS", 5000, minimum=1)
# Messages waiting for the database beyond this are dropped (and counted, loudly).
HISTORY_BUFFER_ROWS = env_int("HISTORY_BUFFER_ROWS", 200_000, minimum=1)
HISTORY_POLICY_RELOAD_S = env_float("HISTORY_POLICY_RELOAD_S", 1.0, minimum=0.05)
HISTORY_PRUNE_EVERY_S = env_float("HISTORY_PRUNE_EVERY_S", 300.0, minimum=1)
HISTORY_MAX_POINTS = env_int("HISTORY_MAX_POINTS", 2000, minimum=10)
# Replay and incidents: camera frames are JPEG files under CAMERA_RECORD_DIR (rows in the database index them).
CAMERA_RECORD_DIR = Path(env_str("CAMERA_RECORD_DIR", str(VAR_DIR / "camera")))
CAMERA_RECORD_FPS = env_float("CAMERA_RECORD_FPS", 2.0, minimum=0.0)  # 0 = the camera is not recorded
CAMERA_RECORD_WIDTH = env_int("CAMERA_RECORD_WIDTH", 320, minimum=16)
CAMERA_RECORD_HEIGHT = env_int("CAMERA_RECORD_HEIGHT", 240, minimum=16)
CAMERA_RECORD_QUALITY = env_int("CAMERA_RECORD_QUALITY", 60, minimum=1)
CAMERA_RETENTION_S = env_float("CAMERA_RETENTION_S", 2 * 86400.0, minimum=60)
# An incident keeps every message of the black box's topics and every camera frame in [t - BEFORE, t + AFTER].
INCIDENT_BEFORE_S = env_float("INCIDENT_BEFORE_S", 60.0, minimum=1)
INCIDENT_AFTER_S = env_float("INCIDENT_AFTER_S", 30.0, minimum=1)
# Scaled, the worker checks every LINK_WATCH_EVERY_S that a robot link runs, and sends the link_down
# alert once none has for LINK_DOWN_ALERT_S (robot.alerts.watchdog).
LINK_WATCH_EVERY_S = env_float("LINK_WATCH_EVERY_S", 5.0, minimum=0.1)
LINK_DOWN_ALERT_S = env_float("LINK_DOWN_ALERT_S", 30.0, minimum=0)
# Each beat job expires just before its next run is due.
CELERY_BEAT_SCHEDULE = {
    name: {"task": task, "schedule": every_s, "options": {"expires": every_s * 0.9}}
    for name, task, every_s in (("history-prune", "history.prune", HISTORY_PRUNE_EVERY_S),
                                ("alerts-link-watch", "alerts.check_links", LINK_WATCH_EVERY_S))
}

# --- API -------------------------------------------------------------------------------
REST_FRAMEWORK = {
    "DEFAULT_AUTHENTICATION_CLASSES": [
        "rest_framework.authentication.SessionAuthentication",
        "robot.api.tokens.CachedTokenAuthentication",
    ],
    "DEFAULT_PERMISSION_CLASSES": ["rest_framework.permissions.IsAuthenticated"],
    "DEFAULT_PARSER_CLASSES": [
        "robot.api.errors.BoundedJSONParser",
        "robot.api.errors.PolicyFormParser",
        "robot.api.errors.PolicyMultiPartParser",
    ],
    "DEFAULT_RENDERER_CLASSES": [
        "robot.api.errors.SafeJSONRenderer",
        "rest_framework.renderers.BrowsableAPIRenderer",
    ],
    "DEFAULT_SCHEMA_CLASS": "robot.api.schema.DocumentedErrorsSchema",
    "DEFAULT_THROTTLE_RATES": {"commands": COMMAND_THROTTLE_RATE},
    "EXCEPTION_HANDLER": "robot.api.errors.api_exception_handler",
}
SPECTACULAR_SETTINGS = {
    "TITLE": "Cyborg Commander API",
    "DESCRIPTION": "Monitor and command the NTNU Cyborg robot.",
    "VERSION": "1.0.0",
    "SERVE_INCLUDE_SCHEMA": False,
    "SWAGGER_UI_DIST": "SIDECAR",
    "SWAGGER_UI_FAVICON_HREF": "SIDECAR",
    "REDOC_DIST": "SIDECAR",
    # Two choice sets are both called "mode": the robot's modes and a topic's recording mode.
    "ENUM_NAME_OVERRIDES": {
        "RobotModeEnum": "robot.commands.validation.MODE_NAMES",
        "RecordingModeEnum": "history.models.Mode",
    },
}

TEST_RUNNER = "cyborg_site.test_runner.PytestTestRunner"

LOGGING = {
    "version": 1,
    "disable_existing_loggers": False,
    "formatters": {"plain": {"format": "%(asctime)s %(levelname)s %(name)s: %(message)s"}},
    "handlers": {"console": {"class": "logging.StreamHandler", "formatter": "plain"}},
    "root": {"handlers": ["console"], "level": env_str("LOG_LEVEL", "INFO")},
    "loggers": {"roslibpy": {"level": "WARNING"}, "daphne": {"level": "WARNING"}},
}
