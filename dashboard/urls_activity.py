# Page routes (issue 4: the command log).
from django.urls import path

from dashboard.views.activity import activity

urlpatterns = [
    path("activity/", activity, name="activity"),
]
