from django.http import HttpRequest, HttpResponse
from django.shortcuts import render

from dashboard.selectors import dashboard_context


def home(request: HttpRequest) -> HttpResponse:
    return render(request, "dashboard/home.html", dashboard_context())
