from django.shortcuts import render

from dashboard.selectors import dashboard_context


def home(request):
    return render(request, "dashboard/home.html", dashboard_context())
