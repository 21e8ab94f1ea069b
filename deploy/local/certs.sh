#!/usr/bin/env bash
# Makes the pflow CA and service certificates for mutual TLS (docs/security.md), with openssl:
#   deploy/local/certs.sh DIR [--host NAME_OR_IP]... manager frontend backend node:NAME ...
# DIR/ca.crt and DIR/ca.key (the CA; keep ca.key off the service hosts in production), then for each argument
# DIR/<file>.crt and DIR/<file>.key whose common name is the identity the services check:
#   manager -> manager.crt, CN pflow-manager        frontend -> frontend.crt, CN pflow-frontend
#   backend -> backend.crt, CN pflow-backend        node:NAME -> node-NAME.crt, CN pflow-node:NAME (its agent and workers)
#   web -> web.crt, CN pflow-web (pflow-web: its HTTPS and its calls to the manager and the back-end)
# Every certificate is valid for localhost, 127.0.0.1, 127.0.0.2, ::1, this host's name and each --host.
# Existing files are kept: rerun it to add a node. To rotate, delete the files (all of them for a new CA) and rerun,
# then restart the services (docs/security.md, "Rotation"). Keys are EC P-256, mode 0600; DAYS (default 825) sets
# the validity.
set -euo pipefail
dir=${1:?usage: certs.sh DIR [--host H]... manager frontend backend node:NAME ...}
shift
days=${DAYS:-825}
hosts=(localhost 127.0.0.1 127.0.0.2 ::1 "$(hostname)")
names=()
while (($#)); do
  case $1 in
    --host) hosts+=("$2"); shift 2 ;;
    *) names+=("$1"); shift ;;
  esac
done
mkdir -p "$dir"
chmod 700 "$dir"
umask 077
if [[ ! -f $dir/ca.crt || ! -f $dir/ca.key ]]; then
  openssl ecparam -name prime256v1 -genkey -noout -out "$dir/ca.key"
  openssl req -x509 -new -key "$dir/ca.key" -sha256 -days "$days" -subj "/O=pflow/CN=pflow CA" \
    -addext "basicConstraints=critical,CA:TRUE" -addext "keyUsage=critical,keyCertSign,cRLSign" -out "$dir/ca.crt" 2>/dev/null
  echo "certs: new CA $dir/ca.crt"
fi
san=""
for h in "${hosts[@]}"; do
  [[ -z $h ]] && continue
  if [[ $h =~ ^[0-9.]+$ || $h == *:* ]]; then san+="IP:$h,"; else san+="DNS:$h,"; fi
done
san=${san%,}
for n in "${names[@]}"; do
  case $n in
    manager | frontend | backend | web) file=$n cn=pflow-$n ;;
    node:*) file=node-${n#node:} cn=pflow-node:${n#node:} ;;
    *) echo "certs: unknown identity '$n' (manager, frontend, backend, web or node:NAME)" >&2; exit 2 ;;
  esac
  [[ -f $dir/$file.crt && -f $dir/$file.key ]] && continue
  openssl ecparam -name prime256v1 -genkey -noout -out "$dir/$file.key"
  openssl req -new -key "$dir/$file.key" -subj "/O=pflow/CN=$cn" -out "$dir/$file.csr"
  printf 'basicConstraints=CA:FALSE\nkeyUsage=critical,digitalSignature,keyEncipherment\nextendedKeyUsage=serverAuth,clientAuth\nsubjectAltName=%s\n' "$san" > "$dir/$file.ext"
  openssl x509 -req -in "$dir/$file.csr" -CA "$dir/ca.crt" -CAkey "$dir/ca.key" -CAcreateserial -days "$days" -sha256 \
    -extfile "$dir/$file.ext" -out "$dir/$file.crt" 2>/dev/null
  rm -f "$dir/$file.csr" "$dir/$file.ext"
  echo "certs: $dir/$file.crt ($cn)"
done
chmod 644 "$dir"/*.crt
