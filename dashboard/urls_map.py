# Page routes of the map (issue 5).
from django.urls import path

from dashboard.views.map import map_image, map_page

urlpatterns = [
    path("map/", map_page, name="map"),
    path("map/image/<str:version>.png", map_image, name="map-image"),
]
