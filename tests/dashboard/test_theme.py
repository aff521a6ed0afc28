"""A person's colour theme: system, light or dark, kept per person; anything else is refused."""

from django.test import Client


def test_it_keeps_each_persons_theme(operator_api, viewer_api):
    assert operator_api.get("/api/me/theme/").json() == {"theme": "system"}
    assert operator_api.patch("/api/me/theme/", {"theme": "dark"}, format="json").json() == {"theme": "dark"}
    assert operator_api.get("/api/me/theme/").json() == {"theme": "dark"}
    assert viewer_api.get("/api/me/theme/").json() == {"theme": "system"}  # each their own


def test_it_refuses_a_theme_it_does_not_have(operator_api):
    res = operator_api.patch("/api/me/theme/", {"theme": "purple"}, format="json")
    assert res.status_code == 400 and "theme" in str(res.json())


def test_pages_are_served_in_the_persons_theme(operator):
    client = Client()
    client.force_login(operator)
    from dashboard.preferences import set_theme

    set_theme(operator, "dark")
    assert '<html lang="en" data-theme="dark">' in client.get("/").content.decode()
