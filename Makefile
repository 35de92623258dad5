# sam build calls build-<Function> with ARTIFACTS_DIR set (BuildMethod: makefile).
# Both functions ship the assembler (the Record schema) and the leaderboard packages, with
# dependencies for the Lambda runtime (Python 3.13 on arm64), whatever machine builds them.
PIP_TARGET_FLAGS = --platform manylinux2014_aarch64 --implementation cp --python-version 3.13 \
	--only-binary=:all: --upgrade --quiet

# The Lambda Python runtime brings these (boto3 and its dependencies): do not ship them twice.
RUNTIME_PROVIDED = boto3 boto3-* botocore botocore-* s3transfer s3transfer-* urllib3 urllib3-* \
	dateutil python_dateutil-* jmespath jmespath-* six.py six-*

build-PushFunction build-PullFunction:
	python3 -m pip install $(PIP_TARGET_FLAGS) --target "$(ARTIFACTS_DIR)" -r functions/requirements.txt
	cd "$(ARTIFACTS_DIR)" && rm -rf $(RUNTIME_PROVIDED)
	cp -R assembler/drboard_assembler functions/drboard_functions "$(ARTIFACTS_DIR)/"
	cd "$(ARTIFACTS_DIR)" && rm -rf bin *-stubs
	find "$(ARTIFACTS_DIR)" \( -name "__pycache__" -o -name "*.pyi" \) -prune -exec rm -rf {} +
	rm -rf "$(ARTIFACTS_DIR)"/*.dist-info/RECORD
