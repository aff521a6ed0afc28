"""The Drive page shows its own "Camera unavailable": its stream asks the server for no placeholder
picture, so the two never lie one over the other."""

from tests.stack import free_port


def test_a_page_that_says_it_itself_gets_no_placeholder_picture(client, viewer, settings):
    settings.VIDEO_URL = f"http://127.0.0.1:{free_port()}"
    client.force_login(viewer)

    response = client.get("/video/stream", {"fallback": "none"})

    assert response.status_code == 503 and response["Retry-After"]
    assert response["Content-Type"].startswith("text/plain")  # an <img> fails on it: the page's placeholder shows
    assert response.content == b"Camera unavailable"


def test_others_still_get_the_placeholder_picture(client, viewer, settings):
    settings.VIDEO_URL = f"http://127.0.0.1:{free_port()}"
    client.force_login(viewer)

    assert client.get("/video/stream")["Content-Type"] == "image/svg+xml"
