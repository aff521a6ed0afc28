from django.contrib import admin
from django.contrib.auth import views as auth_views
from django.templatetags.static import static
from django.urls import include, path
from django.utils.functional import lazy
from django.views.generic import RedirectView

from dashboard.urls import api_urlpatterns as dashboard_api
from history.urls import api_urlpatterns as history_api

urlpatterns = [
    path("admin/", admin.site.urls),
    # Browsers ask for it on pages without an icon link (the admin); not permanent, the name may be hashed.
    # Resolved on the first request: with hashed names the manifest need not exist when URLs load.
    path("favicon.ico", RedirectView.as_view(url=lazy(static, str)("img/cyborg.svg"))),
    path("accounts/login/", auth_views.LoginView.as_view(redirect_authenticated_user=True), name="login"),
    path("accounts/logout/", auth_views.LogoutView.as_view(), name="logout"),
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
