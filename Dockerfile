# seacover in a container: the coordinator (`seacover serve`, the default
# command) and the vessel agent (`seacover agent`) in one small image.
#
#   docker build -t seacover .       # compiles in the official Rust image
#   docker compose up --build        # the fleet demo (docker-compose.yml, README "Docker")
#
# Stages:
#   runtime-base      debian:bookworm-slim with the non-root user, the data
#                     volume, the health check and the command: all but the binary
#   runtime-prebuilt  runtime-base plus a binary built elsewhere, from a build
#                     context holding docker/bin/seacover (scripts/compose-smoke
#                     builds it on the host, where no image can be pulled)
#   build             the release build in the official Rust image
#   runtime           runtime-base plus the binary from `build`: the default
#
# The order matters for Docker's legacy builder (no BuildKit, e.g. Debian
# bookworm's docker.io with docker-compose 1.x), which runs every stage before
# the target: runtime-prebuilt comes before `build`, so building it needs no
# Rust image, and it copies the directory docker/bin/ rather than the binary,
# so a legacy full build, which runs it too, finds that directory in the
# repository. BuildKit skips the stages the target does not need.
#
# No `# syntax=` line: it would make BuildKit fetch a frontend image.

ARG RUST_VERSION=1.95

FROM debian:bookworm-slim AS runtime-base
# A fixed uid, so a bind-mounted data directory can be chowned to it.
RUN groupadd --gid 10001 seacover \
    && useradd --uid 10001 --gid seacover --no-log-init --no-create-home \
        --home-dir /data --shell /usr/sbin/nologin seacover \
    && mkdir /data \
    && chown seacover:seacover /data
COPY docker/bin/seacover-healthcheck /usr/local/bin/
USER seacover
WORKDIR /data
# The mission store (redb, fsynced): keep it in a volume so that it outlives
# the container.
VOLUME /data
EXPOSE 8080
# The binary answers /healthz; the health check asks it through bash's
# /dev/tcp (no curl in the slim base). Agents, which serve nothing, run with
# the check disabled (docker-compose.yml).
HEALTHCHECK --interval=5s --timeout=3s --start-period=10s --retries=3 \
    CMD ["seacover-healthcheck"]
ENTRYPOINT ["seacover"]
# Serving beyond loopback needs a token: set SEACOVER_TOKEN.
CMD ["serve", "--bind", "0.0.0.0:8080", "--data-dir", "/data"]

FROM runtime-base AS runtime-prebuilt
COPY docker/bin/ /usr/local/bin/

FROM rust:${RUST_VERSION}-slim-bookworm AS build
WORKDIR /src
COPY . .
# Debug info off the binary (from 70 MB to 13 MB); symbols stay, so panics
# still name their functions.
RUN cargo build --release --locked \
    && strip --strip-debug target/release/seacover

FROM runtime-base AS runtime
COPY --from=build /src/target/release/seacover /usr/local/bin/seacover
# The binary runs on this base (glibc, libgcc).
RUN ["seacover", "--version"]
