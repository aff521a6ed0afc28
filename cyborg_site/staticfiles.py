"""Static files for production: content-hashed names, so the proxy can let browsers keep them for a year."""

from django.contrib.staticfiles.storage import ManifestStaticFilesStorage


class HashedStaticFiles(ManifestStaticFilesStorage):
    # The pages' JavaScript modules import each other ("./live.js", import("./commands.js")):
    # rewrite those references too, or a browser would pair a new module with a cached old one.
    support_js_module_import_aggregation = True
