from django.urls import path

from robot.frontdoor.views import ticket_view

urlpatterns = [
    path("frontdoor/ticket/", ticket_view, name="api-frontdoor-ticket"),
]
