/* SPDX-License-Identifier: GPL-3.0-or-later */
#define _GNU_SOURCE /* pthread_setname_np */
#include "state_write_behind.h"

#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "state_file.h"

typedef struct job {
  struct job *next;
  char *path;
  void *data;
  size_t size;
} job_t;

/* One writer for the process: state files are the process's (a lock each, state_lock.h). */
static struct {
  bool active;
  pthread_t thread;
  pthread_mutex_t lock;
  pthread_cond_t work;  /* a job was queued, or stopping */
  pthread_cond_t idle;  /* the queue emptied and nothing is being written */
  job_t *head, *tail;
  bool writing;
  bool stopping;
  int failures;         /* since the last report */
  char first_error[512];
} wb = {.lock = PTHREAD_MUTEX_INITIALIZER, .work = PTHREAD_COND_INITIALIZER, .idle = PTHREAD_COND_INITIALIZER};

static void free_job(job_t *j) {
  free(j->path);
  free(j->data);
  free(j);
}

static void *writer_main(void *arg) {
  (void)arg;
  pthread_mutex_lock(&wb.lock);
  for (;;) {
    while (!wb.head && !wb.stopping) {
      pthread_cond_wait(&wb.work, &wb.lock);
    }
    if (!wb.head) {
      break; /* stopping, and everything is written */
    }
    job_t *j = wb.head;
    wb.head = j->next;
    if (!wb.head) {
      wb.tail = NULL;
    }
    wb.writing = true;
    pthread_mutex_unlock(&wb.lock);
    char err[512];
    const int r = state_file_replace_now(j->path, j->data, j->size, err, sizeof(err));
    free_job(j);
    pthread_mutex_lock(&wb.lock);
    wb.writing = false;
    if (r != 0 && wb.failures++ == 0) {
      snprintf(wb.first_error, sizeof(wb.first_error), "%s", err);
    }
    if (!wb.head) {
      pthread_cond_broadcast(&wb.idle);
    }
  }
  pthread_mutex_unlock(&wb.lock);
  return NULL;
}

int state_write_behind_start(char *err, size_t err_len) {
  if (wb.active) {
    return 0;
  }
  wb.stopping = false;
  wb.failures = 0;
  sigset_t all, old; /* signals go to the other threads */
  sigfillset(&all);
  pthread_sigmask(SIG_SETMASK, &all, &old);
  const int rc = pthread_create(&wb.thread, NULL, writer_main, NULL);
  pthread_sigmask(SIG_SETMASK, &old, NULL);
  if (rc != 0) {
    snprintf(err, err_len, "cannot start the state file writer: %s", strerror(rc));
    return -1;
  }
  (void)pthread_setname_np(wb.thread, "ax12-state-file");
  wb.active = true;
  return 0;
}

bool state_write_behind_active(void) { return wb.active; }

/* The failures since the last report, the first one's error in err; the count starts again. */
static int take_failures(char *err, size_t err_len) {
  const int failures = wb.failures;
  if (failures) {
    snprintf(err, err_len, "%s", wb.first_error);
  }
  wb.failures = 0;
  return failures;
}

int state_write_behind_queue(const char *path, const void *data, size_t size, char *err, size_t err_len) {
  void *copy = malloc(size ? size : 1u);
  if (!copy) {
    snprintf(err, err_len, "out of memory for %s", path);
    return -1;
  }
  memcpy(copy, data, size);
  pthread_mutex_lock(&wb.lock);
  job_t *queued = wb.head;
  while (queued && strcmp(queued->path, path) != 0) {
    queued = queued->next;
  }
  if (queued) { /* not yet written: the newer image replaces it */
    free(queued->data);
    queued->data = copy;
    queued->size = size;
  } else {
    job_t *j = calloc(1, sizeof(*j));
    char *path_copy = strdup(path);
    if (!j || !path_copy) {
      pthread_mutex_unlock(&wb.lock);
      free(j);
      free(path_copy);
      free(copy);
      snprintf(err, err_len, "out of memory for %s", path);
      return -1;
    }
    *j = (job_t){.path = path_copy, .data = copy, .size = size};
    if (wb.tail) {
      wb.tail->next = j;
    } else {
      wb.head = j;
    }
    wb.tail = j;
    pthread_cond_signal(&wb.work);
  }
  const int failures = take_failures(err, err_len);
  pthread_mutex_unlock(&wb.lock);
  return failures ? -1 : 0;
}

int state_write_behind_flush(char *err, size_t err_len) {
  pthread_mutex_lock(&wb.lock);
  while (wb.head || wb.writing) {
    pthread_cond_wait(&wb.idle, &wb.lock);
  }
  const int failures = take_failures(err, err_len);
  pthread_mutex_unlock(&wb.lock);
  return failures;
}

int state_write_behind_stop(char *err, size_t err_len) {
  if (!wb.active) {
    return 0;
  }
  pthread_mutex_lock(&wb.lock);
  wb.stopping = true;
  pthread_cond_signal(&wb.work);
  pthread_mutex_unlock(&wb.lock);
  pthread_join(wb.thread, NULL);
  wb.active = false;
  pthread_mutex_lock(&wb.lock);
  const int failures = take_failures(err, err_len);
  pthread_mutex_unlock(&wb.lock);
  return failures;
}
