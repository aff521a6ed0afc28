from django.urls import include, path

urlpatterns = [
    path("", include("robot.api.urls_commands")),
    path("", include("robot.api.urls_navigation")),
    path("", include("robot.api.urls_teleop")),
]
