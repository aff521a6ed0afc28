from django.contrib.auth.decorators import login_required
from django.urls import path
from drf_spectacular.views import SpectacularAPIView, SpectacularSwaggerSplitView
from rest_framework.permissions import IsAuthenticated
from rest_framework.routers import SimpleRouter

from robot.api import alerts, commands, navigation, topics
from robot.api.audit import AuditListView
from robot.api.auth import TokenView
from robot.api.base import API_AUTHENTICATION
from robot.api.state import RobotStateView

router = SimpleRouter()
router.register("locations", navigation.LocationViewSet, basename="api-location")

urlpatterns = [
    path("auth/token/", TokenView.as_view(), name="api-token"),
    path("robot/state/", RobotStateView.as_view(), name="api-robot-state"),
    *(path(f"robot/{name}/", view.as_view(), name=f"api-robot-{name}")
      for name, view in commands.COMMAND_VIEWS.items()),
    path("audit/", AuditListView.as_view(), name="api-audit"),
    path("alerts/", alerts.alerts_view, name="api-alerts"),
    path("alerts/<str:alert_id>/ack/", alerts.acknowledge_view, name="api-alert-ack"),
    path("me/alert-delivery/", alerts.alert_choice_view, name="api-alert-choice"),
    path("me/push-subscriptions/", alerts.push_subscription_view, name="api-push-subscriptions"),
    path("map/", navigation.map_view, name="api-map"),
    path("navigation/goal/", navigation.goal_view, name="api-navigation-goal"),
    path("navigation/cancel/", navigation.cancel_view, name="api-navigation-cancel"),
    path("navigation/status/", navigation.status_view, name="api-navigation-status"),
    path("navigation/initial-pose/", navigation.initial_pose_view, name="api-navigation-initial-pose"),
    path("topics/", topics.topics_view, name="api-topics"),
    path("topics/rate/", topics.rate_view, name="api-topics-rate"),
    *router.urls,
    path("schema/", SpectacularAPIView.as_view(authentication_classes=API_AUTHENTICATION,
                                                 permission_classes=[IsAuthenticated]), name="api-schema"),
    # Swagger UI from drf-spectacular-sidecar's static files: works without internet access. Its start-up
    # script comes from the same URL (?script), not inline: the Content-Security-Policy runs no inline script.
    path("docs/", login_required(SpectacularSwaggerSplitView.as_view(url_name="api-schema")), name="api-docs"),
]
