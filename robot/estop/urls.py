from django.urls import path

from robot.estop.views import EstopReleaseView, EstopView

urlpatterns = [
    path("robot/estop/", EstopView.as_view(), name="robot-estop"),
    path("robot/estop/release/", EstopReleaseView.as_view(), name="robot-estop-release"),
]
