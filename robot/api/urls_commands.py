from django.contrib.auth.decorators import login_required
from django.urls import path
from drf_spectacular.views import SpectacularAPIView, SpectacularSwaggerView
from rest_framework.permissions import IsAuthenticated

from robot.api import commands
from robot.api.audit import AuditListView
from robot.api.auth import TokenView
from robot.api.common import API_AUTHENTICATION
from robot.api.state import RobotStateView

urlpatterns = [
    path("auth/token/", TokenView.as_view(), name="api-token"),
    path("robot/state/", RobotStateView.as_view(), name="api-robot-state"),
    path("robot/mode/", commands.ModeView.as_view(), name="api-robot-mode"),
    path("robot/event/", commands.EventView.as_view(), name="api-robot-event"),
    path("robot/speech/", commands.SpeechView.as_view(), name="api-robot-speech"),
    path("robot/emotion/", commands.EmotionView.as_view(), name="api-robot-emotion"),
    path("robot/emotion-system/", commands.EmotionSystemView.as_view(), name="api-robot-emotion-system"),
    path("robot/motors/", commands.MotorsView.as_view(), name="api-robot-motors"),
    path("robot/playback/", commands.PlaybackView.as_view(), name="api-robot-playback"),
    path("robot/dome/", commands.DomeView.as_view(), name="api-robot-dome"),
    path("audit/", AuditListView.as_view(), name="api-audit"),
    path("schema/", SpectacularAPIView.as_view(authentication_classes=API_AUTHENTICATION,
                                                 permission_classes=[IsAuthenticated]), name="api-schema"),
    # Swagger UI from drf-spectacular-sidecar's static files: works without internet access.
    path("docs/", login_required(SpectacularSwaggerView.as_view(url_name="api-schema")), name="api-docs"),
]
