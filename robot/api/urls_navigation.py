from django.urls import path
from rest_framework.routers import SimpleRouter

from robot.api import navigation

router = SimpleRouter()
router.register("locations", navigation.LocationViewSet, basename="api-location")

urlpatterns = [
    path("map/", navigation.map_view, name="api-map"),
    path("navigation/goal/", navigation.goal_view, name="api-navigation-goal"),
    path("navigation/cancel/", navigation.cancel_view, name="api-navigation-cancel"),
    path("navigation/status/", navigation.status_view, name="api-navigation-status"),
    path("navigation/initial-pose/", navigation.initial_pose_view, name="api-navigation-initial-pose"),
    *router.urls,
]
