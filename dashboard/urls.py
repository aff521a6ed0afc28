"""The pages (namespaced ``dashboard:``) and the page-preferences API (``api_urlpatterns``, under /api/)."""

from django.urls import path

from dashboard.views.account import (
    account,
    account_alerts,
    account_email,
    account_email_verify,
    account_password,
    account_sessions,
    account_token,
)
from dashboard.views.activity import activity
from dashboard.views.alerts import alerts_page
from dashboard.views.drive import drive
from dashboard.views.frontdoor import frontdoor_page
from dashboard.views.health import healthz
from dashboard.views.home import home
from dashboard.views.introspection import diagnostics, statemachine
from dashboard.views.map import costmap_tile, map_image, map_page
from dashboard.views.preferences import map_overlays_view, theme_view
from dashboard.views.topics import topics_page
from dashboard.views.video import video_snapshot, video_stream

app_name = "dashboard"

urlpatterns = [
    path("", home, name="home"),
    path("healthz", healthz, name="healthz"),
    path("activity/", activity, name="activity"),
    path("account/", account, name="account"),
    path("account/email/", account_email, name="account-email"),
    path("account/email/verify/<str:token>/", account_email_verify, name="account-email-verify"),
    path("account/alerts/", account_alerts, name="account-alerts"),
    path("account/token/", account_token, name="account-token"),
    path("account/password/", account_password, name="account-password"),
    path("account/sessions/", account_sessions, name="account-sessions"),
    path("alerts/", alerts_page, name="alerts"),
    path("map/", map_page, name="map"),
    path("map/image/<str:version>.png", map_image, name="map-image"),
    path("map/costmap/<str:layer>/<str:version>/<str:name>.png", costmap_tile, name="costmap-tile"),
    path("drive/", drive, name="drive"),
    path("topics/", topics_page, name="topics"),
    path("rosbridge-tools/", frontdoor_page, name="frontdoor"),
    path("statemachine/", statemachine, name="statemachine"),
    path("diagnostics/", diagnostics, name="diagnostics"),
    path("video/stream", video_stream, name="video-stream"),
    path("video/snapshot", video_snapshot, name="video-snapshot"),
]

api_urlpatterns = [
    path("me/map-overlays/", map_overlays_view, name="api-map-overlays"),
    path("me/theme/", theme_view, name="api-theme"),
]
