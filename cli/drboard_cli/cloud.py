"""Finding a deployed board: the outputs of the organiser's CloudFormation stack."""

from __future__ import annotations

from drboard_functions.errors import BoardNotFound, NotAuthorized

API_URL_OUTPUT = "ApiUrl"


def stack_endpoint(stack_name: str, region: str | None) -> str:
    import boto3
    from botocore.exceptions import BotoCoreError, ClientError, NoCredentialsError

    try:
        client = boto3.client("cloudformation", region_name=region)
        stacks = client.describe_stacks(StackName=stack_name)["Stacks"]
    except NoCredentialsError:
        raise NotAuthorized("no AWS credentials: configure them (aws configure) first") from None
    except ClientError as error:
        raise BoardNotFound(f"stack {stack_name!r}: {error.response['Error']['Message']}") from None
    except BotoCoreError as error:
        raise BoardNotFound(f"stack {stack_name!r}: {error}") from None
    outputs = {o["OutputKey"]: o["OutputValue"] for o in stacks[0].get("Outputs", [])}
    if API_URL_OUTPUT not in outputs:
        raise BoardNotFound(f"stack {stack_name!r} has no {API_URL_OUTPUT} output: is it a drboard stack?")
    return outputs[API_URL_OUTPUT]
