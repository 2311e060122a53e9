# One image for the three processes of the cluster (osw-node a, osw-node b, osw-display) and
# the osw tool. Rendering uses Mesa's lavapipe unless the host passes a GPU through.
FROM rust:1.95-bookworm AS build
WORKDIR /src
COPY . .
RUN cargo build --release --locked --bins

FROM debian:bookworm-slim
RUN apt-get update \
 && apt-get install -y --no-install-recommends mesa-vulkan-drivers libvulkan1 \
 && rm -rf /var/lib/apt/lists/*
COPY --from=build /src/target/release/osw /src/target/release/osw-node /src/target/release/osw-display /usr/local/bin/
COPY configs /etc/osw
ENV XDG_RUNTIME_DIR=/tmp
