from django.urls import path

from robot.api.teleop import EstopView

urlpatterns = [
    path("robot/estop/", EstopView.as_view(), name="robot-estop"),
]
