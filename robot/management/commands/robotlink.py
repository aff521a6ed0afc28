import asyncio
import signal

from django.core.management.base import BaseCommand

from robot.link.hosting import start_link


class Command(BaseCommand):
    help = "Run the robot link: the one rosbridge connection, fan-out to browsers and command relay."

    def handle(self, *args, **options) -> None:
        asyncio.run(self._run())

    async def _run(self) -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        link, tasks = await start_link(embedded=False)
        self.stdout.write(f"Robot link running for {link.url}; Ctrl-C to stop.")
        await stop.wait()
        for task in tasks:
            task.cancel()
        await link.stop()
        self.stdout.write("Robot link stopped.")
