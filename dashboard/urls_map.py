# Page routes (see the issue that owns this page).
urlpatterns: list = []
