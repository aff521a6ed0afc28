from django.contrib import admin
from django.templatetags.static import static
from django.urls import include, path
from django.utils.functional import lazy
from django.views.generic import RedirectView

from dashboard.urls import api_urlpatterns as dashboard_api
from dashboard.views import login
from history.urls import api_urlpatterns as history_api

urlpatterns = [
    path("admin/", admin.site.urls),
    # Browsers ask for it on pages without an icon link (the admin); not permanent, the name may be hashed.
    # Resolved on the first request: with hashed names the manifest need not exist when URLs load.
    path("favicon.ico", RedirectView.as_view(url=lazy(static, str)("img/cyborg.svg"))),
    path("accounts/login/", login.LoginView.as_view(), name="login"),
    path("accounts/logout/", login.LogoutView.as_view(), name="logout"),
    path("accounts/sso/login/", login.sso_login, name="sso-login"),
    path("accounts/sso/callback/", login.sso_callback, name="sso-callback"),
    path("api/", include("robot.estop.urls")),
    path("api/", include("robot.frontdoor.urls")),
    path("api/", include("robot.api.urls")),
    path("api/history/", include(history_api)),
    path("api/", include(dashboard_api)),
    path("history/", include("history.urls")),
    path("", include("dashboard.urls")),
]

handler400 = "dashboard.views.errors.bad_request"
handler403 = "dashboard.views.errors.permission_denied"
handler404 = "dashboard.views.errors.not_found"
handler500 = "dashboard.views.errors.server_error"
