"""JSON Schema questions for the integration tests, answered by Python's
`jsonschema` (pinned in requirements.txt): an implementation of the standard
that shares nothing with the Rust code that generates seacover's schemas.

One question a line on stdin, one answer a line on stdout, each JSON:
  {"schema": S, "instance": I}  ->  the errors of I against S (Draft 2020-12)
  {"meta": S}                   ->  the errors of S against the 2020-12 meta-schema
An answer is a list of messages, "<message> at <instance path>"; [] is valid.
"""

import json
import sys

from jsonschema import Draft202012Validator


def messages(validator, instance):
    return [
        f"{e.message} at /{'/'.join(str(p) for p in e.absolute_path)}"
        for e in validator.iter_errors(instance)
    ]


def main():
    meta = Draft202012Validator(Draft202012Validator.META_SCHEMA)
    validators = {}
    for line in sys.stdin:
        question = json.loads(line)
        if "meta" in question:
            answer = messages(meta, question["meta"])
        else:
            # Many instances are asked of one schema: build its validator once.
            key = json.dumps(question["schema"], sort_keys=True)
            if key not in validators:
                validators[key] = Draft202012Validator(question["schema"])
            answer = messages(validators[key], question["instance"])
        print(json.dumps(answer), flush=True)


if __name__ == "__main__":
    main()
