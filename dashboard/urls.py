from django.urls import path

from dashboard import urls_activity, urls_drive, urls_map
from dashboard.views.health import healthz
from dashboard.views.home import home

app_name = "dashboard"

urlpatterns = [
    path("", home, name="home"),
    path("healthz", healthz, name="healthz"),
    *urls_activity.urlpatterns,
    *urls_map.urlpatterns,
    *urls_drive.urlpatterns,
]
